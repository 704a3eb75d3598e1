// The flags of topics.refine.t and topics.refine.txy, spelled as rost-cli
// spells them. A flag that is a rost setting is the `rostcli` column of its
// row of the settings schema (flag names and, where rost-cli's default
// differs from the schema's, rost-cli's default): its range, documentation
// and error messages come from the schema too. docs/rost-cli.md has the
// whole table.

#include <sched.h>

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <deque>
#include <new>
#include <thread>

#include <CLI/CLI.hpp>

#include "cli_given.hpp"
#include "rost/text_io.hpp"
#include "rostcli.hpp"

namespace rost::cli {

namespace {

// A count of 1 or more (CLI11's PositiveNumber prints its range up to DBL_MAX).
const CLI::Validator& atLeastOne() {
    static const CLI::Validator v(
        [](std::string& s) {
            long long n = 0;
            const char* end = s.data() + s.size();
            const auto r = std::from_chars(s.data(), end, n);
            return r.ec == std::errc() && r.ptr == end && n < 1 ? "expected 1 or more, found '" + s + "'" : std::string();
        },
        "");
    return v;
}


// A flag that is a rost setting: the schema row's `rostcli` column (flag
// names, and rost-cli's default where it differs from the schema's).
struct SettingFlag {
    std::string names;            // CLI11 option names ("-K,--ntopics")
    std::string key;              // the schema key it sets
    std::string rostcli_default;  // rost-cli's default ("": the schema's)
    bool spatial = false;         // topics.refine.t accepts it with any value and ignores it
};

// Every rost-cli setting flag, in the schema's order.
const std::vector<SettingFlag>& settingFlags() {
    static const std::vector<SettingFlag> flags = [] {
        std::vector<SettingFlag> out;
        for (const SettingSpec& spec : settingSpecs()) {
            if (spec.rostcli.empty()) continue;
            SettingFlag f;
            const std::size_t eq = spec.rostcli.find('=');
            f.names = std::string(spec.rostcli.substr(0, eq));
            f.key = std::string(spec.key);
            if (eq != std::string_view::npos) f.rostcli_default = std::string(spec.rostcli.substr(eq + 1));
            f.spatial = spec.key == "g.space" || spec.key == "cell.space";  // cells in space: txy's only
            out.push_back(std::move(f));
        }
        return out;
    }();
    return flags;
}

// rost-cli flags rost cannot reproduce: accepted only with the value that
// changes nothing (`ok`, "" for never), else refused by name.
struct LimitedFlag {
    const char* name;
    const char* ok;
    const char* why;
};
constexpr LimitedFlag kLimitedFlags[] = {
    {"--retime", "true", "rost numbers the documents in input order (rost-cli's --retime=true)"},
    {"--topicmodel.update", "true", "rost always updates the topic model as it refines"},
    {"--out.intermediate.topics", "false", "rost writes the topics at the end only"},
    {"--add.to.topicmodel", "*", "the labels of --in.topics always count in the topic model; accepted with any value"},
    {"--in.topicmask", "", "rost has no topic masks"},
    {"--g.sigma", "", "rost's neighbourhood counts every cell of G(c) alike (no decay)"},
};

// The CPUs this process may run on (its affinity mask), at least 1.
unsigned usableCores() {
    cpu_set_t set;
    CPU_ZERO(&set);
    if (sched_getaffinity(0, sizeof set, &set) == 0 && CPU_COUNT(&set) > 0) return static_cast<unsigned>(CPU_COUNT(&set));
    return std::max(1u, std::thread::hardware_concurrency());
}

bool parseBool(const std::string& s, bool& out) {
    if (s.empty() || s == "true" || s == "1" || s == "yes" || s == "on") return out = true, true;
    if (s == "false" || s == "0" || s == "no" || s == "off") return out = false, true;
    return false;
}

std::string helpOf(const SettingFlag& f, Command cmd) {
    const SettingSpec* spec = findSetting(f.key);
    std::string help = "[";
    help += f.key;
    help += "] ";
    help += spec->doc;
    if (spec->type != SettingType::Bool) help += "; " + settingRange(*spec);
    if (f.spatial && cmd == Command::RefineT) help += " (topics.refine.t: accepted with any value and ignored)";
    return help;
}

std::string defaultOf(const SettingFlag& f) {
    const std::string key = f.key;
    if (key == "V") return "the largest word id + 1";
    if (findSetting(f.key)->has(setting_flags::Cores)) return "the cores this process may use";
    return f.rostcli_default.empty() ? std::string(findSetting(f.key)->def) : f.rostcli_default;
}

struct Parsed {
    RunOptions run;
    std::deque<std::string> setting_text;  // one per settingFlags() row (stable addresses)
    std::vector<CLI::Option*> setting_opts;
    std::deque<std::string> limited_text;
    std::vector<CLI::Option*> limited_opts;
};

} // namespace

const CLI::Validator& wordsInputGiven() {
    static const CLI::Validator v = cli::nonEmpty("file", "for standard input leave -i out, or give -");
    return v;
}

const CLI::Validator& delimiterGiven() {
    static const CLI::Validator v = cli::nonEmpty("delimiter");
    return v;
}

namespace {

void addFileFlags(CLI::App& app, Parsed& p) {
    RunOptions& o = p.run;
    app.add_option("-i,--in.words", o.in_words, "words: a document per line, timestamp,w,w,... (default: standard input)")
        ->check(wordsInputGiven());
    app.add_option("--in.words.delim", o.delim, "the delimiter of the input files")
        ->capture_default_str()
        ->check(delimiterGiven());
    app.add_option("--in.position", o.in_position, "word positions: timestamp,x,y,x,y,... per document (txy)");
    app.add_option("--in.topics", o.in_topics, "start from these labels: timestamp,z,z,... per document (a topics.csv; batch)");
    app.add_option("--in.topicmodel", o.in_topicmodel, "start from this topic model (1 to K rows of V counts), as a prior");
    o.out_topics = "topics.csv";
    o.out_topics_ml = "topics.maxlikelihood.csv";
    o.out_topicmodel = "topicmodel.csv";
    o.ppx_out = "perplexity.csv";
    o.out_position = "topics.position.csv";
    o.logfile = "topics.log";
    o.out_topics_online = "topics.online.csv";
    o.out_ppx_online = "perplexity.online.csv";
    o.out_ppx_iter = "perplexity.iter.csv";
    app.add_option("--out.topics", o.out_topics, "topic labels (the Gibbs sample), timestamp,z,z,...")->capture_default_str();
    app.add_option("--out.topics.ml", o.out_topics_ml, "maximum-likelihood topic labels")->capture_default_str();
    app.add_option("--out.topicmodel", o.out_topicmodel, "the topic model: a row of V counts per topic")->capture_default_str();
    app.add_option("--ppx.out", o.ppx_out, "timestamp,perplexity per document")->capture_default_str();
    app.add_option("--out.position", o.out_position, "the words' positions, per document (txy)")->capture_default_str();
    app.add_option("--logfile", o.logfile, "the run's log: settings, perplexity every --ppx.rate sweeps, speed")->capture_default_str();
    app.add_option("--out.ppx.iter", o.out_ppx_iter, "the corpus perplexity every --ppx.rate sweeps, a number a line (batch)")
        ->capture_default_str();
    app.add_option("--ppx.rate", o.ppx_rate, "sweeps between two perplexity lines of the log and perplexity.iter.csv")->capture_default_str()->check(atLeastOne());
    app.add_flag("--online", o.online, "online: each document is refined for --online.mint ms as it arrives (not reproducible)");
    app.add_option("--out.topics.online", o.out_topics_online, "online: each document's ML labels when its time was up")->capture_default_str();
    app.add_option("--out.ppx.online", o.out_ppx_online, "online: each document's perplexity when its time was up")->capture_default_str();
}

void addSettingFlags(CLI::App& app, Parsed& p, Command cmd) {
    for (const SettingFlag& f : settingFlags()) {
        std::string& text = p.setting_text.emplace_back();
        const SettingType type = findSetting(f.key)->type;
        CLI::Option* opt = app.add_option(f.names, text, helpOf(f, cmd));
        opt->type_name(type == SettingType::Bool ? "[BOOL]" : type == SettingType::Integer ? "INT" : "NUM");
        // --grow.topics.size alone means true: no default string, which CLI11
        // would take as the value of the bare flag.
        if (type == SettingType::Bool) opt->expected(0, 1)->description(opt->get_description() + " (default " + defaultOf(f) + ")");
        else opt->default_str(defaultOf(f));
        opt->group("Model (the settings schema's ranges)");
        p.setting_opts.push_back(opt);
    }
    for (const LimitedFlag& f : kLimitedFlags) {
        std::string& text = p.limited_text.emplace_back();
        std::string help = f.why;
        const std::string ok = f.ok;
        if (ok == "*") help = "accepted and ignored: " + help;
        else if (!ok.empty()) help = "accepted only as " + ok + " (ignoring it then changes nothing): " + help;
        else help = "refused: " + help;
        CLI::Option* opt = app.add_option(f.name, text, help)->expected(0, 1)->type_name(*f.ok == '\0' ? "ANY" : "[BOOL]");
        opt->group("rost-cli flags rost does not reproduce");
        p.limited_opts.push_back(opt);
    }
}

// A setting flag as rost-cli spells it, every alias: "-K/--ntopics", "--gamma".
std::string flagName(std::size_t row) {
    std::string names = settingFlags()[row].names;
    std::replace(names.begin(), names.end(), ',', '/');
    return names;
}

} // namespace

// A setting's problem, each setting named by the flag that sets it (its key when no flag does).
std::string problemText(const SettingProblem& problem) {
    return problem.describe([](const SettingSpec& spec) {
        for (std::size_t i = 0; i < settingFlags().size(); ++i)
            if (spec.key == settingFlags()[i].key) return flagName(i);
        return std::string(spec.key);
    });
}

namespace {

// The setting flags through the schema (rost-cli's defaults where they
// differ), then the limited flags checked.
Status applyFlags(const Parsed& p, Command cmd, Settings& s) {
    for (std::size_t i = 0; i < settingFlags().size(); ++i) {
        const SettingFlag& f = settingFlags()[i];
        const bool given = p.setting_opts[i]->count() > 0;
        if (f.spatial && cmd == Command::RefineT) continue;
        std::string value = given ? p.setting_text[i] : f.rostcli_default;
        if (findSetting(f.key)->has(setting_flags::Cores) && !given)
            value = std::to_string(usableCores());
        if (findSetting(f.key)->type == SettingType::Bool && given && value.empty()) value = "true";
        if (value.empty()) continue;
        // --online.mint is checked without --online too, but is the budget only with it.
        Settings checked = s;
        Settings& into = std::string(f.key) == "budget.ms" && !p.run.online ? checked : s;
        if (auto problem = setSettingText(into, *findSetting(f.key), value)) return Status::error(problemText(*problem));
        if (auto problem = checkSettings(into)) return Status::error(problemText(*problem));
    }
    for (std::size_t i = 0; i < std::size(kLimitedFlags); ++i) {
        const LimitedFlag& f = kLimitedFlags[i];
        if (p.limited_opts[i]->count() == 0 || std::string(f.ok) == "*") continue;
        bool v = false, ok = false;
        if (*f.ok != '\0' && parseBool(p.limited_text[i], v)) ok = v == (std::string(f.ok) == "true");
        if (!ok) {
            std::string msg = f.name;
            if (*f.ok != '\0') {
                msg += " is supported only as ";
                msg += f.ok;
            } else {
                msg += " is not supported";
            }
            msg += " (";
            msg += f.why;
            msg += ')';
            return Status::error(msg);
        }
    }
    return {};
}

} // namespace

int topicsRefineMain(Command cmd, int argc, char** argv) {
    const char* name = cmd == Command::RefineT ? "topics.refine.t" : "topics.refine.txy";
    CLI::App app(cmd == Command::RefineT
                     ? "Topic modelling of documents in time (rost-cli's topics.refine.t, on rost): a document per line"
                     : "Topic modelling of words in time and space (rost-cli's topics.refine.txy, on rost)",
                 name);
    app.footer("Batch mode (the default) is reproducible for a seed, whatever --threads. docs/rost-cli.md lists every "
               "flag and how it differs from rost-cli's.");
    app.option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);  // a repeated flag: the last wins
    Parsed p;
    p.run.cmd = cmd;
    addFileFlags(app, p);
    addSettingFlags(app, p, cmd);
    // A file flag's value that is a flag (`--out.topics --online`) is refused, as the tool refuses it.
    refuseOptionsAsValues(app, [](const CLI::Option* o) {
        const std::string& n = o->get_name();
        return n.rfind("--in.", 0) == 0 || n.rfind("--out.", 0) == 0 || n == "--ppx.out" || n == "--logfile";
    });
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::fprintf(stderr, "%s: %s (see --help)\n", name, text::printable(e.what()).c_str());
        return 2;
    }
    Settings s;
    Status st = applyFlags(p, cmd, s);
    for (std::size_t i = 0; i < settingFlags().size(); ++i)
        if (p.setting_opts[i]->count() > 0) p.run.given.emplace_back(settingFlags()[i].key);
    p.run.v_given = std::find(p.run.given.begin(), p.run.given.end(), "V") != p.run.given.end();
    for (int i = 0; i < argc; ++i) {
        if (i) p.run.command_line += ' ';
        p.run.command_line += argv[i];
    }
    if (st.ok()) {
        try {  // what runRefine did not catch where it happened: one line and exit 2, not an abort
            st = runRefine(p.run, s);
        } catch (const std::bad_alloc&) {
            st = Status::error(StatusKind::OutOfMemory, "out of memory");
        } catch (const std::exception& e) {
            st = Status::error(e.what());
        }
    }
    if (!st.ok()) {
        std::fprintf(stderr, "%s: %s\n", name, text::printable(st.message()).c_str());
        return 2;
    }
    return 0;
}

} // namespace rost::cli
