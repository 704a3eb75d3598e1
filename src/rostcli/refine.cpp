// topics.refine.t / topics.refine.txy after the flags: the model's geometry
// from the input, batch or online refinement, and rost-cli's output files.

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <new>
#include <stdexcept>

#include "rost/engine.hpp"
#include "rost/mission.hpp"
#include "rost/model.hpp"
#include "rost/topic_model_csv.hpp"
#include "rost/text_io.hpp"
#include "rostcli.hpp"

namespace rost::cli {

std::string formatDouble(double v) {
    std::string s;
    text::appendNumber(s, v);
    return s;
}

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

Status set(Settings& s, std::string_view key, const std::string& value) {
    return setSetting(s, key, value);
}

// The largest number of words any one cell of any time step receives; `at`:
// the first document of that time step (for messages).
uint32_t busiestCell(const Corpus& c, const Config& m, std::size_t& at) {
    std::vector<uint32_t> count(static_cast<std::size_t>(m.cellsPerStep()), 0);
    uint32_t most = 0;
    const std::size_t ct = static_cast<std::size_t>(m.cell_time);
    for (std::size_t first = 0; first < c.docs.size(); first += ct) {
        std::fill(count.begin(), count.end(), 0u);
        for (std::size_t d = first; d < std::min(first + ct, c.docs.size()); ++d) {
            for (const Position& p : c.docs[d].positions) {
                const int cell = (p.y / m.cell_space) * m.gridWidth() + p.x / m.cell_space;
                const uint32_t inCell = ++count[static_cast<std::size_t>(cell)];
                if (inCell > most) most = inCell, at = first;
            }
        }
    }
    return most;
}

// The words a refine.t time step holds (all its documents: one cell per step).
uint32_t busiestStep(const Corpus& c, const Config& m, std::size_t& at) {
    uint32_t most = 0;
    const std::size_t ct = static_cast<std::size_t>(m.cell_time);
    for (std::size_t first = 0; first < c.docs.size(); first += ct) {
        uint32_t n = 0;
        for (std::size_t d = first; d < std::min(first + ct, c.docs.size()); ++d)
            n += static_cast<uint32_t>(c.docs[d].words.size());
        if (n > most) most = n, at = first;
    }
    return most;
}

// A batch's model setting out of range because of its input (the longest
// document: max.words; the busiest cell: cell.capacity), with the place in
// the input that asks for it: "words.csv:2 (a document of 1100000 words)".
std::string batchProblem(const SettingProblem& p, const Corpus& c, std::size_t busiest, int cellTime) {
    std::string text = "the model this input needs: " + problemText(p);
    const std::string_view key = p.spec->key;
    if (key != "max.words" && key != "cell.capacity") return text;
    std::size_t at = busiest;
    if (key == "max.words")
        at = static_cast<std::size_t>(
            std::max_element(c.docs.begin(), c.docs.end(),
                             [](const Document& a, const Document& b) { return a.words.size() < b.words.size(); }) -
            c.docs.begin());
    if (at >= c.docs.size()) return text;
    const Document& d = c.docs[at];
    const Document& last = c.docs[std::min(at + static_cast<std::size_t>(std::max(cellTime, 1)), c.docs.size()) - 1];
    text += " (" + c.words_name + ":" + std::to_string(d.line);
    if (key == "max.words" || &last == &d)
        return text + ": a document of " + text::counted(static_cast<long long>(d.words.size()), "word") + ")";
    return text + "-" + std::to_string(last.line) + ": the documents of one time step, --cell.time " +
           std::to_string(cellTime) + "; a smaller one splits them)";
}

// The model for the input, by the library's mission session (rost/mission.hpp),
// as a batch over the whole input: every document stays refinable
// (ring.steps: all of its time steps) and no word is subsampled away
// (max.words: the longest document; cell.capacity: the busiest cell). A
// value out of range is the schema's error, named by rost-cli's flag.
// `stream` null: a stream read as it arrives (topics.refine.t --online),
// sized before its first document: V given, ring.steps and max.words the
// schema's (a window of time steps; older documents leave it with their
// labels as they stand then), every word of a step held (cell.capacity:
// max.words x cell.time).
Status fitModel(const RunOptions& o, const Corpus* stream, Settings& s) {
    if (o.cmd == Command::RefineT) {
        // One cell per time step: a 1x1 frame, no spatial neighbours.
        for (const char* key : {"cell.space", "g.space"})
            if (Status st = set(s, key, key == std::string("g.space") ? "0" : "1"); !st.ok()) return st;
    }
    MissionOptions mission;
    mission.settings = s;
    mission.given = o.given;
    mission.in_topicmodel = o.in_topicmodel;  // V holds its columns too
    std::size_t busiest = 0;  // the first document of the busiest time step (batch)
    if (stream == nullptr)
        mission.names.problem = [](const SettingProblem& p) { return "the model this input needs: " + problemText(p); };
    else
        mission.names.problem = [stream, &busiest, &s](const SettingProblem& p) {
            return batchProblem(p, *stream, busiest, s.engine.model.cell_time);
        };
    MissionInput in;
    if (stream == nullptr) {
        // Online, a cell keeps room for its documents' most words (max.words each) from the start.
        const uint64_t perDoc = static_cast<uint64_t>(s.engine.model.max_words_per_frame);
        const auto most = static_cast<uint64_t>(settingSpec("cell.capacity").hi);
        const auto docs = static_cast<uint64_t>(s.engine.model.cell_time);
        if (perDoc * docs > most)
            return Status::error("--cell.time " + std::to_string(docs) + ": online, a cell keeps room for " +
                                 std::to_string(docs) + " documents of up to " + std::to_string(perDoc) +
                                 " words, more than the " + std::to_string(most) + " a cell can hold (--cell.time " +
                                 std::to_string(std::max<uint64_t>(most / std::max<uint64_t>(perDoc, 1), 1)) + " at most)");
        in.width = in.height = 1;
        in.busiest_cell = [](const Config& m) -> uint64_t {
            return static_cast<uint64_t>(m.max_words_per_frame) * static_cast<uint64_t>(m.cell_time);
        };
    } else {
        const Corpus& c = *stream;
        in.V = c.any_word ? static_cast<int>(c.max_word) + 1 : 1;
        in.width = o.cmd == Command::RefineT ? 1 : c.max_x + 1;
        in.height = o.cmd == Command::RefineT ? 1 : c.max_y + 1;
        in.length = static_cast<int64_t>(c.docs.size());
        in.max_words = std::max<std::size_t>(c.longest, 1);
        in.keep_all = true;
        in.busiest_cell = [&c, &o, &busiest](const Config& m) -> uint64_t {
            return o.cmd == Command::RefineT ? busiestStep(c, m, busiest) : busiestCell(c, m, busiest);
        };
    }
    in.threads = s.engine.model.threads;  // rost-cli's: every usable core unless --threads
    in.flags = s.engine.flags;
    MissionPlan plan;
    if (Status st = planMission(mission, in, plan); !st.ok()) return st;
    s.engine = plan.config;
    return {};
}

// --in.topics: a topics.csv as rost-cli writes it has commas whatever the
// input's delimiter; a file of the user's own may have --in.words.delim. The
// first line says which: the delimiter where it holds one, else commas.
std::string_view topicsDelimiter(std::string_view text, std::string_view delim) {
    const std::string_view first = text.substr(0, text.find('\n'));
    return first.find(delim) == std::string_view::npos && first.find(',') != std::string_view::npos ? "," : delim;
}

void appendLabels(std::string& out, const std::string& timestamp, const std::vector<uint16_t>& z) {
    text::TableWriter t(out);
    t.cell(timestamp);
    for (uint16_t k : z) t.cell(k);
    t.end();
}

// topics.csv (the Gibbs sample), topics.maxlikelihood.csv, perplexity.csv
// (each document's time step, the plug-in perplexity rost-cli reports) and,
// for txy, topics.position.csv: one line per document, labels in input order.
void finalOutputs(const RunOptions& o, const Corpus& c, const Model& model, Outputs& out) {
    std::vector<uint16_t> z;
    for (std::size_t d = 0; d < c.docs.size(); ++d) {
        const Document& doc = c.docs[d];
        z.resize(model.observationSize(d));
        model.observationSamples(d, z);
        appendLabels(out.topics, doc.timestamp, z);
        model.observationLabels(d, z);
        appendLabels(out.topics_ml, doc.timestamp, z);
        text::TableWriter(out.ppx).cell(doc.timestamp).cell(model.stepPluginPerplexity(model.stepOfObservation(d))).end();
        if (o.cmd == Command::RefineTxy) {
            text::TableWriter t(out.position);
            t.cell(doc.timestamp);
            for (const Position& p : doc.positions) t.cell(p.x).cell(p.y);
            t.end();
        }
    }
}

double corpusPerplexity(const Model& model) {
    LogLoss total;
    for (int64_t t = model.oldestStep(); t < model.steps(); ++t) total += model.stepPluginLogLoss(t);
    return total.perplexity();
}

void logLine(Outputs& out, const std::string& line) { out.log += line + "\n"; }

// Batch: every document added, then `final.sweeps` Gibbs sweeps over all of
// them (perplexity logged every ppx.rate sweeps). Reproducible for a seed,
// whatever the threads.
Status runBatch(const RunOptions& o, const Corpus& c, const Settings& s, Model& model, Outputs& out) {
    for (std::size_t d = 0; d < c.docs.size(); ++d) {
        const AddResult r = model.addObservation(c.docs[d].words, c.docs[d].positions, c.docs[d].labels);
        if (!r.ok())
            return Status::error(c.words_name + ":" + std::to_string(c.docs[d].line) + ": " + toString(r.error));
    }
    const int sweeps = s.final_sweeps;
    const uint64_t tokens0 = model.tokensRefined();
    const auto t0 = Clock::now();
    for (int done = 0; done < sweeps;) {
        const int n = std::min(std::max(o.ppx_rate, 1), sweeps - done);
        model.refineAll(n);
        done += n;
        const std::string ppx = formatDouble(corpusPerplexity(model));
        logLine(out, std::string("sweep ") + std::to_string(done) + " perplexity " + ppx);
        out.ppx_iter += ppx + "\n";  // perplexity.iter.csv: a number a line, as rost-cli writes it
    }
    const double secs = secondsSince(t0);
    const uint64_t tokens = model.tokensRefined() - tokens0;
    logLine(out, std::string("refined ") + std::to_string(tokens) + " tokens in " + formatDouble(secs) + " s: " +
                     formatDouble(secs > 0 ? static_cast<double>(tokens) / secs : 0.0) + " token updates/s on " +
                     std::to_string(model.threads()) + " threads");
    return {};
}

struct FileOut {
    const std::string* path;
    const std::string* text;
};

// The files a run writes, each with its text, the log last (a null path: not
// this run's). The online files are written as the run goes: listed to be probed.
std::array<FileOut, 9> outputFiles(const RunOptions& o, const Outputs& out, const std::string& model, bool probing = false) {
    static const std::string none;
    const bool online = o.online && probing;
    return {{{&o.out_topics, &out.topics},
             {&o.out_topics_ml, &out.topics_ml},
             {&o.ppx_out, &out.ppx},
             {o.online ? nullptr : &o.out_ppx_iter, &out.ppx_iter},
             {&o.out_topicmodel, &model},
             {o.cmd == Command::RefineTxy ? &o.out_position : nullptr, &out.position},
             {online ? &o.out_topics_online : nullptr, &none},
             {online ? &o.out_ppx_online : nullptr, &none},
             {&o.logfile, &out.log}}};
}

// Every output this run will write, probed before the input is read or a
// sweep run: an unwritable one fails within a second and writes nothing.
Status probeOutputs(const RunOptions& o) {
    const Outputs none;
    for (const FileOut& f : outputFiles(o, none, none.log, true))
        if (f.path != nullptr && !f.path->empty())
            if (Status st = text::probeOutputFile(*f.path); !st.ok()) return st;
    return {};
}

// A device or FIFO (/dev/null, /dev/stdout): written through, never replaced,
// so two outputs may share it.
bool specialFile(const std::string& path) {
    std::error_code ec;
    const std::filesystem::file_status st = std::filesystem::status(path, ec);
    return !ec && std::filesystem::exists(st) && !std::filesystem::is_regular_file(st) &&
           !std::filesystem::is_directory(st);
}

// No output may replace an input or another output, however spelled (a link
// included): writing there would lose the input or one of the two files
// (and the online files are opened while the input is still being read). The
// one exception is refining in place, a rost-cli habit: the batch outputs
// --out.topicmodel and --out.topics may be the --in.topicmodel and
// --in.topics they started from, read whole before anything is written.
Status checkOutputsApart(const RunOptions& o) {
    struct Named {
        const char* flag;
        const std::string* path;
        const std::string* mayReplace;  // the input it may replace (refining in place), else null
    };
    const std::string* none = nullptr;
    const bool txy = o.cmd == Command::RefineTxy;
    const std::array<Named, 9> outs{{{"--out.topics", &o.out_topics, o.online ? none : &o.in_topics},
                                     {"--out.topics.ml", &o.out_topics_ml, none},
                                     {"--ppx.out", &o.ppx_out, none},
                                     {"--out.ppx.iter", o.online ? none : &o.out_ppx_iter, none},
                                     {"--out.topicmodel", &o.out_topicmodel, &o.in_topicmodel},
                                     {"--out.position", txy ? &o.out_position : none, none},
                                     {"--out.topics.online", o.online ? &o.out_topics_online : none, none},
                                     {"--out.ppx.online", o.online ? &o.out_ppx_online : none, none},
                                     {"--logfile", &o.logfile, none}}};
    for (std::size_t i = 0; i < outs.size(); ++i) {
        const Named& out = outs[i];
        if (out.path == nullptr || out.path->empty() || specialFile(*out.path)) continue;
        MissionOptions inputs;
        if (!isStandardInput(o.in_words)) inputs.inputs.push_back(o.in_words);
        for (const std::string* in : {&o.in_position, &o.in_topics, &o.in_topicmodel})
            if (!in->empty() && in != out.mayReplace) inputs.inputs.push_back(*in);
        if (Status st = checkMissionOutputOverlap(inputs, out.flag, *out.path); !st.ok()) return st;
        for (std::size_t j = 0; j < i; ++j)
            if (outs[j].path != nullptr && !outs[j].path->empty() && sameFile(*out.path, *outs[j].path))
                return Status::error(std::string(out.flag) + ": " + *out.path + " is also " + outs[j].flag +
                                     "'s file: each output needs a file of its own");
    }
    return {};
}

// Writes each non-empty path, all or none: every temporary file is written
// before the first is renamed, so a full disk leaves an earlier run's files
// as they were (text::writeFilesAtomic); the log last.
Status writeOutputs(const RunOptions& o, const Outputs& out, const std::string& model) {
    std::vector<text::FileToWrite> files;
    for (const FileOut& f : outputFiles(o, out, model))
        if (f.path != nullptr && !f.path->empty()) files.push_back({*f.path, *f.text});
    return text::writeFilesAtomic(files);
}

Status readCorpus(const RunOptions& o, const Settings& s, Corpus& c) {
    std::string text, name;
    if (Status st = readInput(o.in_words, text, name); !st.ok()) return st;
    const uint32_t V = o.v_given ? static_cast<uint32_t>(s.engine.model.V) : 0;
    if (Status st = parseDocuments(text, name, o.delim, V, c); !st.ok()) return st;
    if (o.cmd == Command::RefineTxy) {
        if (o.in_position.empty()) return Status::error("topics.refine.txy needs word positions: --in.position FILE");
        if (Status st = readInput(o.in_position, text, name); !st.ok()) return st.prefixed("--in.position: ");
        if (Status st = parsePositions(text, name, o.delim, c); !st.ok()) return st;
    } else {
        for (Document& d : c.docs) d.positions.assign(d.words.size(), Position{0, 0});
    }
    return {};
}

// The settings that made the model; --online runs no final sweeps (its
// budget is on its own "online:" line).
std::string settingsLog(const Settings& s, bool online) {
    std::string out;
    for (const char* key : {"K", "V", "alpha", "beta", "topics.grow", "gamma", "cell.time", "cell.space", "g.time",
                            "g.space", "frame.width", "frame.height", "final.sweeps", "threads", "seed"}) {
        if (online && std::string_view(key) == "final.sweeps") continue;
        out += key;
        out += " = ";
        out += settingValue(s, key);
        out += '\n';
    }
    return out;
}

} // namespace

Status runRefine(const RunOptions& o, Settings& s) {
    if (o.online && !o.in_topics.empty())
        return Status::error("--in.topics starts a batch from given labels; it cannot be used with --online");
    if (Status st = checkOutputsApart(o); !st.ok()) return st;
    if (Status st = probeOutputs(o); !st.ok()) return st;
    // topics.refine.t --online reads its input as it arrives: the model is
    // sized before the first document, so V must be given.
    const bool stream = o.online && o.cmd == Command::RefineT;
    if (stream && !o.v_given)
        return Status::error("--online takes documents up as they arrive, so the vocabulary size must be known "
                             "before the first: give -V/--vocabsize");
    Corpus c;
    if (!stream)
        if (Status st = readCorpus(o, s, c); !st.ok()) return st;
    if (Status st = fitModel(o, stream ? nullptr : &c, s); !st.ok()) return st;
    if (!o.in_topics.empty()) {  // the labels to start from, once K is known
        std::string text, name;
        if (Status st = readInput(o.in_topics, text, name); !st.ok()) return st.prefixed("--in.topics: ");
        if (Status st = parseInitialTopics(text, name, topicsDelimiter(text, o.delim), s.engine.model.K, c); !st.ok())
            return st;
    }
    Outputs out;
    try {
        std::unique_ptr<Engine> engine;
        std::unique_ptr<Model> batch;
        if (o.online) engine = std::make_unique<Engine>(s.engine);
        else batch = std::make_unique<Model>(s.engine.model);
        Model& model = o.online ? engine->model() : *batch;
        if (!o.in_topicmodel.empty())
            if (Status st = loadTopicModelCsv(o.in_topicmodel, model); !st.ok()) return st;
        Status st = o.online ? runOnline(o, c, s, *engine, out) : runBatch(o, c, s, model, out);
        if (!st.ok()) return st;
        if (!o.online) finalOutputs(o, c, model, out);
        out.log = o.command_line + "\n" + std::to_string(c.docs.size()) + " documents from " + c.words_name + "\n" +
                  settingsLog(s, o.online) + out.log;
        logLine(out, std::string("active topics ") + std::to_string(model.activeTopics()) + " of K = " + std::to_string(model.K()));
        return writeOutputs(o, out, formatTopicModelCsv(model));  // a row per open topic, in label order
    } catch (const std::bad_alloc&) {
        return Status::error(std::string("out of memory for a model of ") + std::to_string(c.docs.size()) +
                             " documents (every document is kept refinable; its longest has " +
                             std::to_string(c.longest) + " words)");
    } catch (const std::exception& e) {
        return Status::error(e.what());
    }
}

} // namespace rost::cli
