#pragma once

// rost-cli's drop-in commands (`topics.refine.t`, `topics.refine.txy`,
// `words.bincount`): thin entry points over the library. The flags are
// rost-cli's spellings; every flag that is a rost setting goes through the
// settings schema (rost::setSetting), so its range and error messages are the
// schema's. docs/rost-cli.md has the flag table.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "rost/position.hpp"
#include "rost/settings.hpp"
#include "rost/status.hpp"

namespace rost {
class Engine;
}
namespace CLI {
class Validator;
}

namespace rost::cli {

// -i/--in.words given empty (a script's unset variable): refused, not read as
// standard input, which would wait on a terminal ("-" and /dev/stdin are it).
const CLI::Validator& wordsInputGiven();
// --in.words.delim: an empty delimiter is refused by name.
const CLI::Validator& delimiterGiven();

// ---- input ------------------------------------------------------------------

// One line of a words file: a document (a time step). The timestamp is kept
// exactly as the input wrote it, for the outputs.
struct Document {
    std::string timestamp;
    int line = 0;  // 1-based line in the words file
    std::vector<uint32_t> words;
    std::vector<Position> positions;  // topics.refine.txy only
    std::vector<uint16_t> labels;     // --in.topics: each word's initial topic (empty: drawn)
};

struct Corpus {
    std::vector<Document> docs;
    std::string words_name;  // for messages: the path, or "<stdin>"
    uint32_t max_word = 0;   // largest word id seen
    bool any_word = false;
    std::size_t longest = 0;  // words in the longest document
    int32_t max_x = 0, max_y = 0;
};

// Whether an input path names standard input ("", "-" and "/dev/stdin"):
// read as it comes, no file an output could replace.
bool isStandardInput(const std::string& path);
// The whole of a file, or of standard input for "", "-" and "/dev/stdin".
// `name` receives what messages call it.
Status readInput(const std::string& path, std::string& text, std::string& name);

// Parses `timestamp<d>w<d>w...` lines (d: `delim`); blank lines are skipped.
// Word ids must be integers in [0, V) (V = 0: any id). Errors name the file,
// line and column: "words.csv:3:7: word id 12 out of range [0, 10)".
Status parseDocuments(std::string_view text, std::string_view name, std::string_view delim, uint32_t V,
                      Corpus& out);
// One line of a words file (no '\n'; `number`: its 1-based line, for
// messages) as parseDocuments reads it: `got` is false for a blank line.
// --online reads its input a line at a time with this.
Status parseDocumentLine(std::string_view text, int number, std::string_view name, std::string_view delim, uint32_t V,
                         Document& d, bool& got);
// Parses `timestamp,x,y,x,y,...` lines, one per document of `corpus` in order:
// the same timestamp and two non-negative integer coordinates per word.
Status parsePositions(std::string_view text, std::string_view name, std::string_view delim, Corpus& corpus);
// --in.topics: a document's initial labels a line (timestamp,z,z,...: a
// topics.csv), the documents' timestamps and word counts, each label < K.
Status parseInitialTopics(std::string_view text, std::string_view name, std::string_view delim, int K, Corpus& corpus);

// ---- the commands -----------------------------------------------------------

enum class Command { RefineT, RefineTxy };

// argv as the commands get it; returns the exit code (0, 2 on any error).
int topicsRefineMain(Command cmd, int argc, char** argv);
int wordsBincountMain(int argc, char** argv);

// ---- refinement (refine.cpp) ------------------------------------------------

struct RunOptions {
    Command cmd = Command::RefineT;
    std::string in_words, delim = ",", in_position, in_topicmodel, in_topics;
    std::string out_topics, out_topics_ml, out_topicmodel, ppx_out, out_position, logfile;
    std::string out_topics_online, out_ppx_online;
    std::string out_ppx_iter;  // the corpus perplexity every ppx.rate sweeps (batch)
    bool online = false;
    bool v_given = false;  // -V on the command line (else: the largest word id + 1)
    std::vector<std::string> given;  // the settings' keys whose flags are on the command line
    int ppx_rate = 10;
    std::string command_line;  // for the log file
};

// A setting's problem, each setting named by rost-cli's flag that sets it
// ("-K/--ntopics"; its key when no flag does).
std::string problemText(const SettingProblem& problem);

// Everything after the flags are parsed and the settings set: reads the
// input, refines, writes the outputs (temporary file, then rename).
Status runRefine(const RunOptions& o, Settings& settings);

// The outputs' text, built in memory and written at the end (the online
// files are written line by line instead).
struct Outputs {
    std::string topics, topics_ml, ppx, ppx_iter, position, log;
};

// --online (online.cpp): the documents of `c` (topics.refine.txy: read with
// their positions) or, when it holds none, of the words input read as it
// arrives, each pushed into the running engine and refined for the time
// budget; each one's online line appended and flushed when its time is up.
// Ends at the end of the input, SIGINT or SIGTERM (the log says which); then
// `out` holds the final files' text and `c` the documents (without words).
Status runOnline(const RunOptions& o, Corpus& c, const Settings& s, Engine& engine, Outputs& out);

// A number as the shortest text that parses back to it ("nan" for NaN).
std::string formatDouble(double v);

} // namespace rost::cli
