// words.bincount -i IN -o OUT -V N: per input line `timestamp,c_0,...,c_{N-1}`,
// the histogram of the line's labels (e.g. topics.maxlikelihood.csv -> the
// topic mix of each document). The timestamp is copied as the input wrote it.

#include <cstdio>
#include <new>

#include <CLI/CLI.hpp>

#include "rost/mission.hpp"
#include "rost/text_io.hpp"
#include "rostcli.hpp"

namespace rost::cli {

namespace {

struct BincountOptions {
    std::string in, out, V, delim = ",";
};

Status bincount(const BincountOptions& o) {
    Settings s;  // -V through the schema: its range and message
    if (auto p = setSettingText(s, settingSpec("V"), o.V)) return Status::error(p->describe("-V"));
    if (auto p = checkSettings(s)) return Status::error(p->describe(p->spec->key == "V" ? "-V" : p->spec->key));
    const bool toStdout = o.out.empty() || o.out == "-" || o.out == "/dev/stdout";
    if (!toStdout) {
        if (Status st = text::probeOutputFile(o.out); !st.ok()) return st;  // before reading the input
        // The output replacing its own input (however spelled): refused, as topics.refine.t refuses it.
        MissionOptions inputs;
        if (!isStandardInput(o.in)) inputs.inputs.push_back(o.in);
        if (Status st = checkMissionOutputOverlap(inputs, "-o/--out", o.out); !st.ok()) return st;
    }
    const auto bins = static_cast<uint32_t>(s.engine.model.V);
    std::string text, name;
    if (Status st = readInput(o.in, text, name); !st.ok()) return st;
    Corpus c;
    if (Status st = parseDocuments(text, name, o.delim, bins, c); !st.ok()) return st;
    std::string out;
    text::TableWriter table(out);
    std::vector<uint32_t> count(bins);
    for (const Document& d : c.docs) {
        std::fill(count.begin(), count.end(), 0u);
        for (uint32_t w : d.words) ++count[w];
        table.cell(d.timestamp);
        for (uint32_t n : count) table.cell(n);
        table.end();
    }
    if (o.out.empty() || o.out == "-" || o.out == "/dev/stdout") {
        if (std::fwrite(out.data(), 1, out.size(), stdout) != out.size() || std::fflush(stdout) != 0)
            return Status::error("<stdout>: write error");
        return {};
    }
    return text::writeFileAtomic(o.out, out);
}

} // namespace

int wordsBincountMain(int argc, char** argv) {
    CLI::App app("Histogram of each line's labels (rost-cli's words.bincount, on rost): per input line "
                 "timestamp,c_0,...,c_{V-1}",
                 "words.bincount");
    app.option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
    BincountOptions o;
    app.add_option("-i,--in.words", o.in, "labels: timestamp,z,z,... per line (default: standard input)")
        ->check(wordsInputGiven());
    app.add_option("-o,--out", o.out, "the histograms (default: standard output)");
    app.add_option("-V,--vocabsize", o.V, "bins: labels are 0..V-1 [the schema's V: " + settingRange(*findSetting("V")) + "]")
        ->required();
    app.add_option("--in.words.delim", o.delim, "the delimiter of the input")->capture_default_str()->check(delimiterGiven());
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::fprintf(stderr, "words.bincount: %s (see --help)\n", text::printable(e.what()).c_str());
        return 2;
    }
    Status st;
    try {  // one line and exit 2, not an abort
        st = bincount(o);
    } catch (const std::bad_alloc&) {
        st = Status::error(StatusKind::OutOfMemory, "out of memory");
    }
    if (!st.ok()) {
        std::fprintf(stderr, "words.bincount: %s\n", text::printable(st.message()).c_str());
        return 2;
    }
    return 0;
}

} // namespace rost::cli
