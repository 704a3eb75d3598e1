// rost-cli's drop-in commands end to end, as a rost-cli user's pipeline runs
// them: documents with planted topics written to a words file,
// topics.refine.t (batch, online, standard input), words.bincount on the
// maximum-likelihood topics, topics.refine.txy on planted spatial structure;
// every output read back by its format (no headers) and checked: shapes,
// sums, verbatim timestamps, recovery of the planted topics, reproducibility,
// and errors that name the file, line and column with exit status 2.

#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <set>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

constexpr int kTopics = 4, kWordsPerTopic = 10, kV = kTopics * kWordsPerTopic;
constexpr int kDocs = 240, kDocWords = 24, kSegment = 20;

std::string readText(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

void writeText(const std::string& path, const std::string& text) {
    std::ofstream f(path, std::ios::binary);
    f << text;
}

// Lines of a headerless CSV, each split at commas (fields as text).
std::vector<std::vector<std::string>> csv(const std::string& path) {
    std::vector<std::vector<std::string>> rows;
    std::istringstream in(readText(path));
    std::string line;
    while (std::getline(in, line)) {
        std::vector<std::string> row;
        std::string field;
        std::istringstream ls(line);
        while (std::getline(ls, field, ',')) row.push_back(field);
        rows.push_back(std::move(row));
    }
    return rows;
}

struct Result {
    int status = -1;
    std::string err;
};

// Runs a shell command line in `dir`; stderr captured.
Result run(const std::string& dir, const std::string& cmd) {
    const std::string errPath = dir + "/stderr.txt";
    const std::string line = "cd '" + dir + "' && " + cmd + " 2>'" + errPath + "'";
    const int rc = std::system(line.c_str());
    Result r;
    r.status = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
    r.err = readText(errPath);
    return r;
}

std::string bin(const char* path) { return std::string("'") + path + "'"; }

// A planted stream: the documents come in segments of kSegment, each segment
// about one topic (its words drawn from that topic's kWordsPerTopic words),
// the topics in a seeded random order. Timestamps are decimal text that a
// number parser would not give back verbatim ("12.50").
struct Planted {
    std::vector<int> topic;  // per document
    std::vector<std::string> stamp;
    std::vector<std::vector<int>> words;
};

Planted plant(unsigned seed) {
    std::mt19937 rng(seed);
    Planted p;
    int t = 0;
    for (int d = 0; d < kDocs; ++d) {
        if (d % kSegment == 0) t = (t + 1 + static_cast<int>(rng() % (kTopics - 1))) % kTopics;
        p.topic.push_back(t);
        p.stamp.push_back(std::to_string(d / 2) + (d % 2 ? ".50" : ".00"));
        std::vector<int> w;
        for (int i = 0; i < kDocWords; ++i) w.push_back(t * kWordsPerTopic + static_cast<int>(rng() % kWordsPerTopic));
        p.words.push_back(std::move(w));
    }
    return p;
}

std::string wordsCsv(const Planted& p) {
    std::string out;
    for (std::size_t d = 0; d < p.words.size(); ++d) {
        out += p.stamp[d];
        for (int w : p.words[d]) {
            out += ',';
            out += std::to_string(w);
        }
        out += "\n";
    }
    return out;
}

class RostCli : public ::testing::Test {
protected:
    void SetUp() override {
        std::string name = "rostcli-";
        name += ::testing::UnitTest::GetInstance()->current_test_info()->name();
        name += '-';
        name += std::to_string(::getpid());
        dir = (fs::temp_directory_path() / name).string();
        fs::remove_all(dir);
        fs::create_directories(dir);
        planted = plant(7);
        writeText(dir + "/words.csv", wordsCsv(planted));
    }
    void TearDown() override {
        if (!HasFailure()) fs::remove_all(dir);
    }
    std::string dir;
    Planted planted;
};

// Labels per document as integers; checks one line per document, the
// timestamps verbatim, one label per word, every label below `K`.
std::vector<std::vector<int>> labels(const std::string& path, const Planted& p, int K) {
    const auto rows = csv(path);
    EXPECT_EQ(rows.size(), p.words.size()) << path;
    std::vector<std::vector<int>> out;
    for (std::size_t d = 0; d < std::min(rows.size(), p.words.size()); ++d) {
        EXPECT_EQ(rows[d][0], p.stamp[d]) << path << " line " << d + 1;
        EXPECT_EQ(rows[d].size(), p.words[d].size() + 1) << path << " line " << d + 1;
        std::vector<int> z;
        for (std::size_t i = 1; i < rows[d].size(); ++i) {
            z.push_back(std::stoi(rows[d][i]));
            EXPECT_GE(z.back(), 0);
            EXPECT_LT(z.back(), K) << path << " line " << d + 1;
        }
        out.push_back(std::move(z));
    }
    return out;
}

// Purity of per-document histograms (rows of `timestamp,c_0..c_{K-1}`) against
// the planted topics: each learned topic is credited to the planted topic it
// most often dominates; the share of documents whose dominant learned topic
// maps to their own planted topic.
double purity(const std::vector<std::vector<long long>>& hist, const std::vector<int>& planted) {
    std::map<int, std::map<int, int>> votes;  // learned -> planted -> documents
    std::vector<int> dominant;
    for (const auto& h : hist) dominant.push_back(static_cast<int>(std::max_element(h.begin(), h.end()) - h.begin()));
    for (std::size_t d = 0; d < dominant.size(); ++d) ++votes[dominant[d]][planted[d]];
    int right = 0;
    for (std::size_t d = 0; d < dominant.size(); ++d) {
        const auto& v = votes[dominant[d]];
        const int best = std::max_element(v.begin(), v.end(), [](auto& a, auto& b) { return a.second < b.second; })->first;
        right += best == planted[d];
    }
    return static_cast<double>(right) / static_cast<double>(dominant.size());
}

// words.bincount's output: checks the shape and that each row sums to the document's words.
std::vector<std::vector<long long>> histograms(const std::string& path, const Planted& p, int K) {
    const auto rows = csv(path);
    EXPECT_EQ(rows.size(), p.words.size());
    std::vector<std::vector<long long>> out;
    for (std::size_t d = 0; d < std::min(rows.size(), p.words.size()); ++d) {
        EXPECT_EQ(rows[d][0], p.stamp[d]);
        EXPECT_EQ(rows[d].size(), static_cast<std::size_t>(K) + 1);
        std::vector<long long> h;
        for (std::size_t i = 1; i < rows[d].size(); ++i) h.push_back(std::stoll(rows[d][i]));
        long long sum = 0;
        for (long long c : h) sum += c;
        EXPECT_EQ(sum, static_cast<long long>(p.words[d].size())) << "line " << d + 1;
        out.push_back(std::move(h));
    }
    return out;
}

// topicmodel.csv: `rows` rows of kV counts adding up to every word of the input.
void checkTopicModel(const std::string& path, std::size_t rows, long long words) {
    const auto m = csv(path);
    ASSERT_EQ(m.size(), rows);
    long long total = 0;
    for (const auto& r : m) {
        ASSERT_EQ(r.size(), static_cast<std::size_t>(kV));
        for (const auto& c : r) total += std::stoll(c);
    }
    EXPECT_EQ(total, words);
}

// `timed`: each document was refined for a time budget (--online), so one the
// machine starved (a sanitizer build, a busy host) may not have learned yet:
// nine in ten must have, not every one.
void checkPerplexity(const std::string& path, const Planted& p, bool timed = false) {
    const auto rows = csv(path);
    ASSERT_EQ(rows.size(), p.words.size());
    std::size_t learned = 0;
    for (std::size_t d = 0; d < rows.size(); ++d) {
        ASSERT_EQ(rows[d].size(), 2u);
        EXPECT_EQ(rows[d][0], p.stamp[d]);
        const double ppx = std::stod(rows[d][1]);
        EXPECT_TRUE(std::isfinite(ppx) && ppx >= 1.0) << "line " << d + 1 << ": " << ppx;
        // A document of one planted topic: about kWordsPerTopic equally likely words.
        if (ppx < kV) ++learned;
        else if (!timed) ADD_FAILURE() << "line " << d + 1 << ": perplexity " << ppx << " of " << kV << " words";
    }
    EXPECT_GE(learned * 10, rows.size() * 9) << learned << " of " << rows.size() << " documents below " << kV;
}

const std::string kRefineFlags =
    " --out.topics=topics.csv --out.topics.ml=topics.maxlikelihood.csv --out.topicmodel=topicmodel.csv"
    " --ppx.out=perplexity.csv --logfile=topics.log -V 40 -K 4 --alpha=0.1 --beta=0.5 --g.time=1"
    " --cell.space=0 --g.space 0 -n 60 --seed 3";

TEST_F(RostCli, PipelineRecoversPlantedTopicsAndIsReproducible) {
    const long long total = static_cast<long long>(kDocs) * kDocWords;
    Result r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv" + kRefineFlags + " --threads 2");
    ASSERT_EQ(r.status, 0) << r.err;
    labels(dir + "/topics.csv", planted, 4);
    labels(dir + "/topics.maxlikelihood.csv", planted, 4);
    checkTopicModel(dir + "/topicmodel.csv", 4, total);
    checkPerplexity(dir + "/perplexity.csv", planted);
    EXPECT_NE(readText(dir + "/topics.log").find("token updates/s"), std::string::npos);

    r = run(dir, bin(ROSTCLI_BINCOUNT) + " -i topics.maxlikelihood.csv -o topics.hist.csv -V 4");
    ASSERT_EQ(r.status, 0) << r.err;
    const double pur = purity(histograms(dir + "/topics.hist.csv", planted, 4), planted.topic);
    EXPECT_GE(pur, 0.95) << "planted topics not recovered";

    // Same seed, one thread, words from standard input: the same bytes.
    const std::string first = readText(dir + "/topics.csv") + readText(dir + "/topics.maxlikelihood.csv") +
                              readText(dir + "/topicmodel.csv") + readText(dir + "/perplexity.csv");
    fs::create_directories(dir + "/again");
    r = run(dir + "/again", bin(ROSTCLI_REFINE_T) + kRefineFlags + " --threads 1 < ../words.csv");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(readText(dir + "/again/topics.csv") + readText(dir + "/again/topics.maxlikelihood.csv") +
                  readText(dir + "/again/topicmodel.csv") + readText(dir + "/again/perplexity.csv"),
              first);
    // Another seed: another sample.
    r = run(dir + "/again", bin(ROSTCLI_REFINE_T) + " -i ../words.csv" + kRefineFlags + " --seed=4");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(readText(dir + "/again/topics.csv"), readText(dir + "/topics.csv"));
}

TEST_F(RostCli, OnlineWritesEachDocumentAsItArrivedAndTheFinalFiles) {
    Result r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv" + kRefineFlags +
                         " --online --out.topics.online=topics.online.csv --out.ppx.online=perplexity.online.csv"
                         " --online.mint 5");
    ASSERT_EQ(r.status, 0) << r.err;
    const auto online = labels(dir + "/topics.online.csv", planted, 4);
    checkPerplexity(dir + "/perplexity.online.csv", planted, true);
    labels(dir + "/topics.maxlikelihood.csv", planted, 4);
    checkTopicModel(dir + "/topicmodel.csv", 4, static_cast<long long>(kDocs) * kDocWords);
    // Each document's labels as they stood when it arrived still follow the planted topics.
    std::vector<std::vector<long long>> hist;
    for (const auto& z : online) {
        std::vector<long long> h(4, 0);
        for (int k : z) ++h[static_cast<std::size_t>(k)];
        hist.push_back(h);
    }
    EXPECT_GE(purity(hist, planted.topic), 0.8);
    r = run(dir, bin(ROSTCLI_BINCOUNT) + " -V 4 < topics.maxlikelihood.csv > hist.csv");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_GE(purity(histograms(dir + "/hist.csv", planted, 4), planted.topic), 0.9);
}

// With growth (--grow.topics.size=true --gamma): K is the cap, topicmodel.csv
// holds the A active topics, every label is below A, and the planted topics
// are recovered: as many as the documents use, whatever gamma.
TEST_F(RostCli, GrowthWritesTheActiveTopicsAndRecoversThePlantedOnes) {
    const std::string flags =
        " -i words.csv -V 40 -K 16 -n 60 --g.time 1 --cell.space 0 --seed 3 --grow.topics.size=true --gamma=0.01";
    Result r = run(dir, bin(ROSTCLI_REFINE_T) + flags);
    ASSERT_EQ(r.status, 0) << r.err;
    const std::size_t A = csv(dir + "/topicmodel.csv").size();
    // Exactly the planted topics the documents use (a regime's topic; some
    // seeds leave one of the kTopics out), and no junk topic beside them.
    const std::set<int> used(planted.topic.begin(), planted.topic.end());
    EXPECT_EQ(A, used.size()) << "the planted topics in use";
    checkTopicModel(dir + "/topicmodel.csv", A, static_cast<long long>(kDocs) * kDocWords);
    labels(dir + "/topics.csv", planted, static_cast<int>(A));
    labels(dir + "/topics.maxlikelihood.csv", planted, static_cast<int>(A));
    r = run(dir, bin(ROSTCLI_BINCOUNT) + " -i topics.maxlikelihood.csv -o hist.csv -V " + std::to_string(A));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_GE(purity(histograms(dir + "/hist.csv", planted, static_cast<int>(A)), planted.topic), 0.9);
    // Without growth the same run has K topics; --grow.topics.size alone means true.
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -V 40 -K 16 -n 2 --gamma=0.01 --out.topicmodel=k.csv");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(csv(dir + "/k.csv").size(), 16u);
    r = run(dir, bin(ROSTCLI_REFINE_T) + flags + " --grow.topics.size --out.topicmodel=g.csv");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(readText(dir + "/g.csv"), readText(dir + "/topicmodel.csv"));
    // A growth run's topicmodel.csv (A rows) reads back as a prior: its A topics
    // first, the rest empty; with growth those A are open from the start.
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -V 40 -K 16 -n 0 --seed 3 --grow.topics.size=true"
                                         " --gamma=1e-9 --in.topicmodel=g.csv --out.topicmodel=back.csv");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(csv(dir + "/back.csv").size(), A) << "the prior's topics are the open ones";
}

// topics.refine.txy: each document holds words at positions in a 64 x 32
// frame; the left half speaks one planted topic, the right half another,
// and the pair changes every kSegment documents.
TEST_F(RostCli, TxyRecoversPlantedSpatialTopics) {
    std::mt19937 rng(11);
    std::string words, pos;
    std::vector<int> truth;  // per word, all documents in order
    for (int d = 0; d < 120; ++d) {
        const int a = (d / kSegment) % kTopics, b = (a + 2) % kTopics;
        words += std::to_string(d);
        pos += std::to_string(d);
        for (int i = 0; i < 30; ++i) {
            const int x = static_cast<int>(rng() % 64), y = static_cast<int>(rng() % 32);
            const int t = x < 32 ? a : b;
            truth.push_back(t);
            words += ',';
            words += std::to_string(t * kWordsPerTopic + static_cast<int>(rng() % kWordsPerTopic));
            pos += ',';
            pos += std::to_string(x);
            pos += ',';
            pos += std::to_string(y);
        }
        words += "\n";
        pos += "\n";
    }
    writeText(dir + "/txy.csv", words);
    writeText(dir + "/pos.csv", pos);
    Result r = run(dir, bin(ROSTCLI_REFINE_TXY) +
                         " -i txy.csv --in.position=pos.csv -V 40 -K 4 --cell.space 16 --g.space 1 --g.time 1 -n 60"
                         " --beta 0.5 --threads 2");
    ASSERT_EQ(r.status, 0) << r.err;
    const auto ml = csv(dir + "/topics.maxlikelihood.csv");
    ASSERT_EQ(ml.size(), 120u);
    std::map<int, std::map<int, int>> votes;
    std::vector<int> got;
    for (const auto& row : ml)
        for (std::size_t i = 1; i < row.size(); ++i) got.push_back(std::stoi(row[i]));
    ASSERT_EQ(got.size(), truth.size());
    for (std::size_t i = 0; i < got.size(); ++i) ++votes[got[i]][truth[i]];
    int right = 0;
    for (std::size_t i = 0; i < got.size(); ++i) {
        const auto& v = votes[got[i]];
        right += std::max_element(v.begin(), v.end(), [](auto& x, auto& y) { return x.second < y.second; })->first ==
                 truth[i];
    }
    EXPECT_GE(static_cast<double>(right) / static_cast<double>(got.size()), 0.9);
    EXPECT_EQ(readText(dir + "/topics.position.csv"), pos);
    checkTopicModel(dir + "/topicmodel.csv", 4, 120 * 30);
}

// A topic model carried from one run to the next (--out.topicmodel ->
// --in.topicmodel) is a prior the new run keeps and adds its own words to;
// another delimiter (--in.words.delim) reads the same documents.
TEST_F(RostCli, TopicModelCarriesOverAndDelimiterIsHonoured) {
    const long long total = static_cast<long long>(kDocs) * kDocWords;
    Result r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -V 40 -K 4 -n 30 --out.topicmodel=first.csv");
    ASSERT_EQ(r.status, 0) << r.err;
    checkTopicModel(dir + "/first.csv", 4, total);
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -V 40 -K 4 -n 30 --in.topicmodel=first.csv");
    ASSERT_EQ(r.status, 0) << r.err;
    checkTopicModel(dir + "/topicmodel.csv", 4, 2 * total);
    const auto prior = csv(dir + "/first.csv"), both = csv(dir + "/topicmodel.csv");
    for (std::size_t k = 0; k < 4; ++k)
        for (std::size_t v = 0; v < static_cast<std::size_t>(kV); ++v)
            EXPECT_GE(std::stoll(both[k][v]), std::stoll(prior[k][v])) << "topic " << k << " word " << v;
    r = run(dir, bin(ROSTCLI_BINCOUNT) + " -i topics.maxlikelihood.csv -o hist.csv -V 4");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_GE(purity(histograms(dir + "/hist.csv", planted, 4), planted.topic), 0.95);
    // Fewer rows than K load (the rest start empty), rows shorter than V too
    // (a model of fewer words: the rest count 0); more rows than K, or rows
    // longer than V, are an error naming the file, the line and K or V.
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -V 40 -K 5 -n 1 --in.topicmodel=first.csv");
    EXPECT_EQ(r.status, 0) << r.err;
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -V 40 -K 3 --in.topicmodel=first.csv");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("first.csv:4:1: more than K = 3 topic lines"), std::string::npos) << r.err;
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -V 41 -K 4 -n 1 --in.topicmodel=first.csv");
    EXPECT_EQ(r.status, 0) << r.err;
    std::string wide;  // 41 counts a line
    for (const auto& row : prior) {
        for (const auto& f : row) (wide += f) += ',';
        wide += "0\n";
    }
    writeText(dir + "/wide.csv", wide);
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -V 40 -K 4 --in.topicmodel=wide.csv");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("wide.csv:1:"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("more than V = 40 counts"), std::string::npos) << r.err;

    std::string semi = readText(dir + "/words.csv");
    std::replace(semi.begin(), semi.end(), ',', ';');
    writeText(dir + "/semi.csv", semi);
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -V 40 -K 4 -n 5 --out.topics=comma.csv");
    ASSERT_EQ(r.status, 0) << r.err;
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i semi.csv --in.words.delim ';' -V 40 -K 4 -n 5 --out.topics=semi-topics.csv");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(readText(dir + "/semi-topics.csv"), readText(dir + "/comma.csv"));
    // The run's own topics.csv (commas, as every output) starts a run on the ';' input.
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i semi.csv --in.words.delim ';' -V 40 -K 4 -n 0 --in.topics semi-topics.csv"
                                         " --out.topics=again.csv");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(readText(dir + "/again.csv"), readText(dir + "/semi-topics.csv"));
    // V from the topic model too: a model of more words than the input uses loads without -V.
    writeText(dir + "/w4.csv", "0,1,2\n1,3\n");
    writeText(dir + "/tm5.csv", "1,2,3,4,5\n0,0,0,0,9\n");
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i w4.csv -K 3 -n 2 --in.topicmodel tm5.csv --out.topicmodel=tm-out.csv");
    ASSERT_EQ(r.status, 0) << r.err;
    const auto rows = csv(dir + "/tm-out.csv");
    ASSERT_FALSE(rows.empty());
    EXPECT_EQ(rows[0].size(), 5u) << "V = 5, the topic model's columns";
}

// Bad input: one line naming the file, line and column; exit 2; no outputs.
TEST_F(RostCli, ErrorsNameFileLineAndColumnAndLeaveNoOutputs) {
    writeText(dir + "/bad.csv", "0,1,2\n1,3,x4,5\n");
    Result r = run(dir, bin(ROSTCLI_REFINE_T) + " -i bad.csv -V 40 -K 4");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.t: bad.csv:2:5: expected word id (a non-negative integer), found 'x4'\n");
    writeText(dir + "/big.csv", "0,1,2\n1,3,40\n");
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i big.csv -V 40 -K 4");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.t: big.csv:2:5: word id 40 out of range [0, 40)\n");
    r = run(dir, bin(ROSTCLI_BINCOUNT) + " -i big.csv -V 40 -o h.csv");  // label V: outside the V bins
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "words.bincount: big.csv:2:5: word id 40 out of range [0, 40)\n");
    // V not given: a word beyond the most V may be is named where it is, and so is a
    // position beyond the largest frame.
    writeText(dir + "/huge.csv", "0,1,2\n1,3,4294967295\n");
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i huge.csv -K 4");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.t: huge.csv:2:5: word id 4294967295 out of range [0, 16777216)\n");
    writeText(dir + "/far.csv", "0,1,1,2,2\n1,2147483646,0,1,1\n");
    writeText(dir + "/w2.csv", "0,1,2\n1,3,4\n");
    r = run(dir, bin(ROSTCLI_REFINE_TXY) + " -i w2.csv --in.position far.csv -K 4");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.txy: far.csv:2:3: x 2147483646 out of range [0, 65536)\n");
    writeText(dir + "/p.csv", "0,1,2\n1,3,40,5\n");
    writeText(dir + "/w.csv", "0,1\n1,3,4\n");
    r = run(dir, bin(ROSTCLI_REFINE_TXY) + " -i w.csv --in.position p.csv -V 40 -K 4");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.txy: p.csv:2:9: 3 coordinates for the 2 words of w.csv:2 (expected x,y per word: 4)\n");
    // A side file of other documents (shifted, another run's) is not paired
    // with these line by line: its time stamps, and its lines, must match.
    writeText(dir + "/shifted.csv", "0,1,2\n2,3,4,5,6\n");
    r = run(dir, bin(ROSTCLI_REFINE_TXY) + " -i w.csv --in.position shifted.csv -V 40 -K 4");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.txy: shifted.csv:2:1: timestamp '2' differs from w.csv:2's '1'\n");
    writeText(dir + "/short.csv", "0,1,2\n");
    r = run(dir, bin(ROSTCLI_REFINE_TXY) + " -i w.csv --in.position short.csv -V 40 -K 4");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.txy: short.csv:2:1: 1 position lines for the 2 documents of w.csv\n");
    // A side file that cannot be read is named by its flag (a line of one by its place).
    r = run(dir, bin(ROSTCLI_REFINE_TXY) + " -i w.csv --in.position . -V 40 -K 4");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.txy: --in.position: .: is a directory, not a file\n");
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i w.csv --in.topics gone.csv -V 40 -K 4");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.t: --in.topics: gone.csv: cannot open: No such file or directory\n");
    writeText(dir + "/long.csv", "0,1,2\n1,3,4,5,6\n2,7,8\n");
    r = run(dir, bin(ROSTCLI_REFINE_TXY) + " -i w.csv --in.position long.csv -V 40 -K 4");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.txy: long.csv:3:1: a position line beyond the 2 documents of w.csv\n");
    // A file name, or a word, with a newline, an escape or a C1 control is printed escaped, on one line.
    const std::string odd = "b\na\x1b[2J\xC2\x9B" "d";
    writeText(dir + "/" + odd + ".csv", "0,1,2\n1,3,x\x1b\n");
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i '" + odd + ".csv' -V 40 -K 4");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.t: b\\x0aa\\x1b[2J\\u009bd.csv:2:5: expected word id (a non-negative integer), found 'x\\x1b'\n");
    r = run(dir, bin(ROSTCLI_BINCOUNT) + " -i '" + odd + ".csv' -V 40 -o h.csv --in.words.delim '\x1b'");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "words.bincount: b\\x0aa\\x1b[2J\\u009bd.csv: no words in its 2 documents (each line is "
                     "timestamp\\x1bword\\x1bword...)\n");
    r = run(dir, bin(ROSTCLI_BINCOUNT) + " -V 40 '" + odd + "'");  // an argument CLI11 refuses, quoted in its error
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "words.bincount: The following argument was not expected: b\\x0aa\\x1b[2J\\u009bd (see --help)\n");
    for (const char* f : {"topics.csv", "topics.maxlikelihood.csv", "topicmodel.csv", "perplexity.csv", "topics.log"})
        EXPECT_FALSE(fs::exists(dir + "/" + f)) << f;
    // An empty -i (a script's unset variable) is refused, not read as standard input.
    for (const char* cmd : {ROSTCLI_REFINE_T, ROSTCLI_BINCOUNT}) {
        r = run(dir, bin(cmd) + " -i '' -V 5 < bad.csv");
        EXPECT_EQ(r.status, 2) << cmd;
        EXPECT_NE(r.err.find(": --in.words: no file given (for standard input leave -i out, or give -)"),
                  std::string::npos) << r.err;
    }
    r = run(dir, bin(ROSTCLI_BINCOUNT) + " -i bad.csv -V 5 -o h.csv");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "words.bincount: bad.csv:2:5: expected word id (a non-negative integer), found 'x4'\n");
    r = run(dir, bin(ROSTCLI_BINCOUNT) + " -i words.csv -V 5 -o h.csv");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("words.csv:1:"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir + "/h.csv"));
}

// A batch keeps every word: a document (or a time step of them) that is more than a
// cell can hold is refused naming the lines that ask for it, not only the setting.
TEST_F(RostCli, ADocumentTooLargeForACellIsNamedByItsLines) {
    std::string big = "0,1,2\n1";
    for (int i = 0; i < 1100000; ++i) big += ",3";
    writeText(dir + "/big.csv", big + "\n");
    Result r = run(dir, bin(ROSTCLI_REFINE_T) + " -i big.csv -V 5 -K 2 -n 1");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.t: the model this input needs: cell.capacity = 1100000, allowed [1, 1048576] "
                     "(big.csv:2: a document of 1100000 words)\n");
    std::string steps = "0,1\n";  // a document of one word, then 7 of 300000: the second time step is the busiest
    for (int t = 1; t <= 7; ++t) {
        steps += std::to_string(t);
        for (int i = 0; i < 300000; ++i) steps += ",3";
        steps += "\n";
    }
    writeText(dir + "/steps.csv", steps);
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i steps.csv -V 5 -K 2 -n 1 --cell.time 4");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.t: the model this input needs: cell.capacity = 1200000, allowed [1, 1048576] "
                     "(steps.csv:5-8: the documents of one time step, --cell.time 4; a smaller one splits them)\n");
    EXPECT_FALSE(fs::exists(dir + "/topics.csv"));
}

// words.bincount -o /dev/stdout (or -) writes to the standard output it was
// given, as rost-cli did: a script's `>> all.csv` appends, and replaces nothing.
TEST_F(RostCli, BincountToStandardOutputAppendsWhereTheShellSaysSo) {
    writeText(dir + "/w.csv", "0,1,1,2\n1,3\n");
    for (const char* out : {"/dev/stdout", "-"}) {
        writeText(dir + "/all.csv", "earlier\n");
        const Result r = run(dir, bin(ROSTCLI_BINCOUNT) + " -i w.csv -V 4 -o " + out + " >> all.csv");
        ASSERT_EQ(r.status, 0) << out << ": " << r.err;
        EXPECT_EQ(readText(dir + "/all.csv"), "earlier\n0,0,2,1,0\n1,0,0,0,1\n") << out;
    }
}

// Flags: schema ranges with the schema's words, rost-cli flags rost cannot
// reproduce refused by name, spatial flags accepted by topics.refine.t.
TEST_F(RostCli, FlagsGoThroughTheSchema) {
    Result r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -K 0");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("topics.refine.t: -K/--ntopics = 0, allowed [1, 1024]"), std::string::npos) << r.err;
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv --alpha=x");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("topics.refine.t: -a/--alpha: expected a finite number, found 'x'"), std::string::npos) << r.err;
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -n -1");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("topics.refine.t: -n/--iter = -1, allowed [0, 1000000]"), std::string::npos) << r.err;
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv --g.sigma 0.5");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("--g.sigma is not supported"), std::string::npos) << r.err;
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv --retime=false");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("--retime is supported only as true"), std::string::npos) << r.err;
    for (const std::string& tool : {bin(ROSTCLI_REFINE_T), bin(ROSTCLI_BINCOUNT) + " -V 4"}) {
        r = run(dir, tool + " -i words.csv --in.words.delim ''");
        EXPECT_EQ(r.status, 2);
        EXPECT_NE(r.err.find("--in.words.delim: no delimiter given"), std::string::npos) << r.err;
    }
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv --no.such.flag 1");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("no.such.flag"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir + "/topics.csv"));
    // Spatial settings mean nothing to topics.refine.t: any value, 0 included.
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -V 40 -K 4 -n 2 --cell.space 0 --g.space=-3 --retime"
                                         " --grow.topics.size=false --add.to.topicmodel=false");
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(csv(dir + "/topics.csv").size(), static_cast<std::size_t>(kDocs));
    // The spellings of a boolean rost-cli's scripts use: each taken where the flag's one value is.
    for (const std::string yes : {"true", "1", "yes", "on"}) {
        r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -K 2 -n 1 --retime " + yes);
        EXPECT_EQ(r.status, 0) << yes << ": " << r.err;
    }
    for (const std::string no : {"false", "0", "no", "off"}) {
        r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -K 2 -n 1 --out.intermediate.topics " + no);
        EXPECT_EQ(r.status, 0) << no << ": " << r.err;
    }
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -K 2 -n 1 --out.intermediate.topics nope");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("--out.intermediate.topics is supported only as false"), std::string::npos) << r.err;
    r = run(dir, bin(ROSTCLI_REFINE_T) + " --help > help.txt");
    EXPECT_EQ(r.status, 0);
    const std::string help = readText(dir + "/help.txt");
    for (const char* f : {"--in.words", "--out.topics.ml", "--ppx.out", "--grow.topics.size", "--online.mint", "--g.sigma"})
        EXPECT_NE(help.find(f), std::string::npos) << f;
    // Defaults that are not numbers: the machine's (the schema's Cores) and the input's.
    EXPECT_NE(help.find("--threads INT=the cores this process may use"), std::string::npos) << help;
    EXPECT_NE(help.find("--vocabsize INT=the largest word id + 1"), std::string::npos) << help;
}

// Every setting flag sets its own key: each at a value other than its
// default, read back from topics.log (the table is written out here, as
// rost-cli's documentation names the flags, not derived from the schema).
TEST_F(RostCli, EverySettingFlagSetsItsOwnKey) {
    std::string words, positions;  // 8 documents of 4 words on a 10 x 10 frame: 4 steps of cell.time 2
    for (int d = 0; d < 8; ++d) {
        words += std::to_string(d);
        positions += std::to_string(d);
        for (int i = 0; i < 4; ++i) {
            words += ',';
            words += std::to_string((d * 3 + i * 5) % 9);
            positions += ',';
            positions += std::to_string((d + i * 3) % 10);
            positions += ',';
            positions += std::to_string((d * 7 + i) % 10);
        }
        words += "\n";
        positions += "\n";
    }
    writeText(dir + "/d.csv", words);
    writeText(dir + "/p.csv", positions);
    const std::vector<std::pair<std::string, std::string>> flags = {
        {"-K 7", "K = 7"},          {"-V 41", "V = 41"},          {"--alpha 0.25", "alpha = 0.25"},
        {"--beta 0.75", "beta = 0.75"}, {"--gamma 0.003", "gamma = 0.003"}, {"--cell.time 2", "cell.time = 2"},
        {"--g.time 3", "g.time = 3"}, {"-n 3", "final.sweeps = 3"}, {"--threads 2", "threads = 2"},
        {"--seed 99", "seed = 99"}, {"--grow.topics.size true", "topics.grow = true"},
        {"--cell.space 4", "cell.space = 4"}, {"--g.space 2", "g.space = 2"}};
    std::string args;
    for (const auto& [flag, line] : flags) {
        args += ' ';
        args += flag;
    }
    const Result r = run(dir, bin(ROSTCLI_REFINE_TXY) + " -i d.csv --in.position p.csv --logfile=flags.log" + args);
    ASSERT_EQ(r.status, 0) << r.err;
    const std::string log = readText(dir + "/flags.log");
    for (const auto& [flag, line] : flags)
        EXPECT_NE(log.find(line + '\n'), std::string::npos) << flag << " should give '" << line << "' in:\n" << log;
}

// rost-cli's own defaults where they differ from rost's (the schema row's
// rostcli column: gamma 1e-5, cell.space 32, 100 iterations), read back from
// topics.log of a run that gives none of those flags; rost's own defaults
// (gamma 1e-4, cell.space 64, no final sweeps) would be a different run.
TEST_F(RostCli, ItsOwnDefaultsApplyWhereTheyDifferFromRosts) {
    writeText(dir + "/d.csv", "0,1,2,3\n1,3,2,1\n");
    writeText(dir + "/p.csv", "0,1,1,2,2,3,3\n1,1,1,2,2,3,3\n");
    const Result r = run(dir, bin(ROSTCLI_REFINE_TXY) +
                                  " -i d.csv --in.position p.csv -V 5 -K 3 --grow.topics.size true --logfile=d.log");
    ASSERT_EQ(r.status, 0) << r.err;
    const std::string log = readText(dir + "/d.log");
    for (const char* line : {"gamma = 1e-05\n", "cell.space = 32\n", "final.sweeps = 100\n"})
        EXPECT_NE(log.find(line), std::string::npos) << "expected '" << line << "' in:\n" << log;
}

// --ppx.out holds each document's plug-in perplexity, as rost-cli reports it
// (every count as it stands, the word's own label included). With one topic
// theta is 1 and p(w) = (n_w + beta) / (N + V beta) over the whole input:
// documents {0, 0, 1} and {1, 2} of V = 3 give 6.5 / 2.5 and
// 6.5 / sqrt(2.5 * 1.5); the left-out perplexity would give others.
TEST_F(RostCli, PpxOutIsThePluginPerplexityOfEachDocument) {
    writeText(dir + "/k1.csv", "0,0,0,1\n1,1,2\n");
    const Result r = run(dir, bin(ROSTCLI_REFINE_T) + " -i k1.csv -V 3 -K 1 --alpha 0.1 --beta 0.5 -n 3 --ppx.out=pp.csv");
    ASSERT_EQ(r.status, 0) << r.err;
    std::istringstream in(readText(dir + "/pp.csv"));
    double expected[] = {6.5 / 2.5, 6.5 / std::sqrt(2.5 * 1.5)};
    std::string line;
    for (int d = 0; d < 2; ++d) {
        ASSERT_TRUE(std::getline(in, line)) << "document " << d;
        const std::size_t comma = line.find(',');
        ASSERT_NE(comma, std::string::npos) << line;
        EXPECT_EQ(line.substr(0, comma), std::to_string(d));
        EXPECT_NEAR(std::stod(line.substr(comma + 1)), expected[d], 1e-12 * expected[d]) << line;
    }
}

// perplexity.iter.csv, as rost-cli writes it by default: the corpus
// perplexity every --ppx.rate sweeps, one number a line, the same numbers as
// the log's "sweep N perplexity X" lines; --out.ppx.iter "" writes none, and
// an online run (no sweeps) none.
TEST_F(RostCli, PerplexityIterHoldsTheCorpusPerplexityEveryPpxRateSweeps) {
    writeText(dir + "/k1.csv", "0,0,0,1\n1,1,2\n2,2,2,0\n");
    Result r = run(dir, bin(ROSTCLI_REFINE_T) + " -i k1.csv -V 3 -K 2 -n 25 --ppx.rate 10");
    ASSERT_EQ(r.status, 0) << r.err;
    std::istringstream iter(readText(dir + "/perplexity.iter.csv"));
    std::vector<std::string> values;
    for (std::string line; std::getline(iter, line);) values.push_back(line);
    ASSERT_EQ(values.size(), 3u) << "after sweeps 10, 20 and 25";
    const std::string log = readText(dir + "/topics.log");
    const int sweeps[] = {10, 20, 25};
    for (std::size_t i = 0; i < values.size(); ++i) {
        EXPECT_GT(std::stod(values[i]), 1.0) << values[i];
        const std::string logged = "sweep " + std::to_string(sweeps[i]) + " perplexity " + values[i] + "\n";
        EXPECT_NE(log.find(logged), std::string::npos) << "expected '" << logged << "' in the log:\n" << log;
    }
    // The last is the corpus's: every document's perplexity.csv value (its
    // step's, cell.time 1) weighted by its words, all of them, the last too.
    std::istringstream per(readText(dir + "/perplexity.csv"));
    const int words[] = {3, 2, 3};
    double logSum = 0.0;
    int d = 0;
    for (std::string line; std::getline(per, line) && d < 3; ++d) logSum += words[d] * std::log(std::stod(line.substr(line.find(',') + 1)));
    ASSERT_EQ(d, 3);
    EXPECT_NEAR(std::stod(values.back()), std::exp(logSum / 8.0), 1e-9 * std::stod(values.back()));
    std::filesystem::remove(dir + "/perplexity.iter.csv");
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i k1.csv -V 3 -K 2 -n 5 --out.ppx.iter ''");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir + "/perplexity.iter.csv"));
    // A rate below 1 is named with its value, not with a range up to DBL_MAX's 309 digits.
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i k1.csv -V 3 -K 2 -n 5 --ppx.rate 0");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.t: --ppx.rate: expected 1 or more, found '0' (see --help)\n");
}

// A flag where a value is due is refused, naming both, as the tool refuses
// it: `--out.topics --online` wrote a batch run's labels to a file named
// "--online"; a file named like a flag is given as ./--name.
TEST_F(RostCli, AFlagWhereAValueIsDueIsRefusedNamingBoth) {
    writeText(dir + "/k1.csv", "0,1,2\n1,2,0\n");
    Result r = run(dir, bin(ROSTCLI_REFINE_T) + " -i k1.csv -V 3 -K 2 -n 5 --out.topics --online");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.t: --out.topics: needs a value; --online is an option (a file of that name: "
                     "./--online) (see --help)\n");
    EXPECT_FALSE(std::filesystem::exists(dir + "/--online"));
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i k1.csv -V 3 -n 5 -K --threads 2");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.t: --ntopics: needs a value; --threads is an option (see --help)\n");
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i k1.csv -V 3 -K 2 -n 5 --out.topics ./--online");
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(std::filesystem::exists(dir + "/--online"));
}

// Positions with fractions (rostpy's, a spectrogram's) are placed at their
// floor: the same run as the positions with their fractions cut, every output
// byte for byte; a negative one is still refused, naming it.
TEST_F(RostCli, FractionalPositionsArePlacedAtTheirFloor) {
    writeText(dir + "/w.csv", "0,1,2,3\n1,3,2,1\n2,0,0,4\n");
    writeText(dir + "/frac.csv", "0,0.5,1.25,17.9,3,40.01,2.5\n1,1.5,0.75,3.999,31.5,8,8\n2,0,0,63.5,31.9,5.5,6\n");
    writeText(dir + "/cut.csv", "0,0,1,17,3,40,2\n1,1,0,3,31,8,8\n2,0,0,63,31,5,6\n");
    const std::string files[] = {"topics.csv", "topics.maxlikelihood.csv", "perplexity.csv", "topicmodel.csv",
                                 "topics.position.csv", "perplexity.iter.csv"};
    std::map<std::string, std::string> out[2];
    for (int run_ = 0; run_ < 2; ++run_) {
        const Result r = run(dir, bin(ROSTCLI_REFINE_TXY) + " -i w.csv --in.position " +
                                      (run_ == 0 ? "frac.csv" : "cut.csv") + " -V 5 -K 3 -n 20 --seed 4");
        ASSERT_EQ(r.status, 0) << r.err;
        for (const std::string& f : files) out[run_][f] = readText(dir + "/" + f);
    }
    for (const std::string& f : files) EXPECT_EQ(out[0][f], out[1][f]) << f;
    writeText(dir + "/neg.csv", "0,0,1,-0.5,3,4,2\n1,1,0,3,31,8,8\n2,0,0,63,31,5,6\n");
    const Result r = run(dir, bin(ROSTCLI_REFINE_TXY) + " -i w.csv --in.position neg.csv -V 5 -K 3 -n 2");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("neg.csv:1:7: expected x (a non-negative number), found '-0.5'"), std::string::npos) << r.err;
}

// Positions are taken up to the largest frame, y as far as x: a frame taller
// than wide (y past every x) is sized by its y; a coordinate of 65536 (or
// 65536.0) is named by file, line and column, 65535.5 placed at 65535.
TEST_F(RostCli, PositionsAreTakenUpToTheLargestFrameAndNamedPastIt) {
    writeText(dir + "/w.csv", "0,1,2\n1,3\n");
    writeText(dir + "/tall.csv", "0,0,5,1,9\n1,0,7\n");
    Result r = run(dir, bin(ROSTCLI_REFINE_TXY) + " -i w.csv --in.position tall.csv -K 2 --threads 1");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(readText(dir + "/topics.position.csv"), "0,0,5,1,9\n1,0,7\n");
    writeText(dir + "/w1.csv", "0,1\n");
    const std::pair<std::string, std::string> past[] = {
        {"0,65536,0", "q.csv:1:3: x 65536 out of range [0, 65536)"},
        {"0,65536.0,0", "q.csv:1:3: expected x (a non-negative number), found '65536.0'"},
        {"0,0,65536", "q.csv:1:5: y 65536 out of range [0, 65536)"},
        {"0,0,65536.0", "q.csv:1:5: expected y (a non-negative number), found '65536.0'"}};
    for (const auto& [line, error] : past) {
        writeText(dir + "/q.csv", line + "\n");
        r = run(dir, bin(ROSTCLI_REFINE_TXY) + " -i w1.csv --in.position q.csv -K 2 --threads 1");
        EXPECT_EQ(r.status, 2) << line;
        EXPECT_EQ(r.err, "topics.refine.txy: " + error + "\n") << line;
    }
    writeText(dir + "/q.csv", "0,0,65535.5\n");
    r = run(dir, bin(ROSTCLI_REFINE_TXY) + " -i w1.csv --in.position q.csv -K 2 --threads 1 --cell.space 64");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(readText(dir + "/topics.position.csv"), "0,0,65535\n");
}

// --in.topics starts a batch from given labels (a topics.csv): with no
// sweeps its topics.csv is those labels; a label of K or more, or a line of
// another document, is named by file, line and column; --online refuses it.
TEST_F(RostCli, InTopicsStartsFromGivenLabels) {
    writeText(dir + "/w.csv", "0,1,2,3\n1,3,2,1\n2,0,0,4\n");
    writeText(dir + "/z.csv", "0,2,2,0\n1,1,0,1\n2,2,1,0\n");
    Result r = run(dir, bin(ROSTCLI_REFINE_T) + " -i w.csv -V 5 -K 3 -n 0 --in.topics z.csv --out.topics=t0.csv");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(readText(dir + "/t0.csv"), readText(dir + "/z.csv"));
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i w.csv -V 5 -K 3 -n 10 --in.topics z.csv");
    ASSERT_EQ(r.status, 0) << r.err;
    writeText(dir + "/big.csv", "0,2,2,0\n1,1,3,1\n2,2,1,0\n");
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i w.csv -V 5 -K 3 -n 1 --in.topics big.csv");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("big.csv:2:5: topic label 3 out of range [0, 3)"), std::string::npos) << r.err;
    writeText(dir + "/short.csv", "0,2,2,0\n1,1,0\n2,2,1,0\n");
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i w.csv -V 5 -K 3 -n 1 --in.topics short.csv");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("short.csv:2:6: 2 labels for the 3 words of w.csv:2"), std::string::npos) << r.err;
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i w.csv -V 5 -K 3 --online --in.topics z.csv");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("--in.topics starts a batch from given labels; it cannot be used with --online"),
              std::string::npos) << r.err;
}

// No output may replace an input or another output, however spelled (a link
// included): refused before anything is opened or read (an online file used
// to empty its own input before the input was read, and a batch output
// replaced it). Refining in place, --out.topicmodel over --in.topicmodel and
// --out.topics over --in.topics, is a rost-cli habit, and taken: the inputs
// are read whole before anything is written.
TEST_F(RostCli, AnOutputThatIsAnInputOrAnotherOutputIsRefusedBeforeAnythingIsWritten) {
    const std::string words = readText(dir + "/words.csv");
    fs::create_symlink("words.csv", dir + "/link.csv");
    const std::string replace = ": writing there would replace it";
    const struct {
        std::string flags, err;
    } cases[] = {
        {"--online -V 40 --online.mint 1 --out.ppx.online words.csv",
         "--out.ppx.online: words.csv is an input of this run" + replace},
        {"--online -V 40 --online.mint 1 --out.topics.online ./words.csv",
         "--out.topics.online: ./words.csv is the same file as the input words.csv" + replace},
        {"--out.topics words.csv", "--out.topics: words.csv is an input of this run" + replace},
        {"--logfile link.csv", "--logfile: link.csv is the same file as the input words.csv" + replace},
        {"--out.topics same.csv --out.topics.ml same.csv",
         "--out.topics.ml: same.csv is also --out.topics's file: each output needs a file of its own"},
        {"--ppx.out p.csv --out.ppx.iter ./p.csv",
         "--out.ppx.iter: ./p.csv is also --ppx.out's file: each output needs a file of its own"},
    };
    for (const auto& c : cases) {
        const Result r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -K 4 -n 2 " + c.flags);
        EXPECT_EQ(r.status, 2) << c.flags;
        EXPECT_EQ(r.err, "topics.refine.t: " + c.err + "\n") << c.flags;
        EXPECT_EQ(readText(dir + "/words.csv"), words) << c.flags << ": the input changed";
        for (const char* f : {"topics.csv", "topics.maxlikelihood.csv", "topicmodel.csv", "perplexity.csv", "topics.log",
                              "topics.online.csv", "perplexity.online.csv", "same.csv", "p.csv"})
            EXPECT_FALSE(fs::exists(dir + "/" + f)) << c.flags << ": " << f;
    }
    // txy's positions are an input too.
    writeText(dir + "/w.csv", "0,1,2\n1,3,4\n");
    writeText(dir + "/pos.csv", "0,0,0,1,1\n1,2,2,3,3\n");
    Result r = run(dir, bin(ROSTCLI_REFINE_TXY) + " -i w.csv --in.position pos.csv -K 2 -n 1 --out.position pos.csv");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.txy: --out.position: pos.csv is an input of this run" + replace + "\n");
    // In place: the model and the labels a run starts from are its outputs' defaults.
    ASSERT_EQ(run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -K 4 -n 2").status, 0);
    const std::string model = readText(dir + "/topicmodel.csv"), labels = readText(dir + "/topics.csv");
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -K 4 -n 5 --in.topicmodel topicmodel.csv --in.topics topics.csv");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(readText(dir + "/topicmodel.csv"), model) << "refined in place";
    EXPECT_NE(readText(dir + "/topics.csv"), labels) << "refined in place";
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -K 4 -n 1 --in.topics topics.csv --out.topics.ml topics.csv");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.t: --out.topics.ml: topics.csv is an input of this run" + replace + "\n");
    // words.bincount: the same rule; a device written through is no file to replace.
    const std::string ml = readText(dir + "/topics.maxlikelihood.csv");
    r = run(dir, bin(ROSTCLI_BINCOUNT) + " -i topics.maxlikelihood.csv -o ./topics.maxlikelihood.csv -V 4");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "words.bincount: -o/--out: ./topics.maxlikelihood.csv is the same file as the input "
                     "topics.maxlikelihood.csv" + replace + "\n");
    EXPECT_EQ(readText(dir + "/topics.maxlikelihood.csv"), ml);
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -K 4 -n 1 --out.topics /dev/null --out.topics.ml /dev/null");
    EXPECT_EQ(r.status, 0) << r.err;
}

// --online: the online files are opened when their first line is written,
// so a run refused at its first document leaves an earlier run's as they
// were (they used to be emptied at the start).
TEST_F(RostCli, AnOnlineRunThatFailsAtItsFirstDocumentLeavesTheEarlierOnlineFiles) {
    Result r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -V 40 -K 4 --online --online.mint 1");
    ASSERT_EQ(r.status, 0) << r.err;
    const std::string topics = readText(dir + "/topics.online.csv"), ppx = readText(dir + "/perplexity.online.csv");
    ASSERT_EQ(std::count(topics.begin(), topics.end(), '\n'), kDocs);
    writeText(dir + "/bad.csv", "0,1,x\n1,2\n");
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i bad.csv -V 40 -K 4 --online --online.mint 1");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.t: bad.csv:1:5: expected word id (a non-negative integer), found 'x'\n");
    EXPECT_EQ(readText(dir + "/topics.online.csv"), topics);
    EXPECT_EQ(readText(dir + "/perplexity.online.csv"), ppx);
}

// A device output that fails (/dev/full) fails the run before any file is
// renamed: the earlier run's files stay whole, never a mix of two runs (the
// devices were written after the renames before).
TEST_F(RostCli, ADeviceOutputThatFailsLeavesTheEarlierRunsFiles) {
    Result r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -V 40 -K 4 -n 2 --seed 1");
    ASSERT_EQ(r.status, 0) << r.err;
    const char* files[] = {"topics.csv", "perplexity.csv", "topicmodel.csv", "topics.log"};
    std::vector<std::string> before;
    for (const char* f : files) before.push_back(readText(dir + "/" + f));
    r = run(dir, bin(ROSTCLI_REFINE_T) + " -i words.csv -V 40 -K 4 -n 2 --seed 2 --out.topics.ml /dev/full");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.t: /dev/full: write failed: No space left on device\n");
    for (std::size_t i = 0; i < std::size(files); ++i) EXPECT_EQ(readText(dir + "/" + files[i]), before[i]) << files[i];
}

// An online write that fails (here a file size limit, as a full disk) is cut
// back to the last whole line, so a reader never sees half a line; the error
// names the file.
TEST_F(RostCli, AnOnlineFileThatCannotBeWrittenKeepsWholeLinesOnly) {
    const Result r = run(dir, "(trap '' XFSZ; ulimit -f 4; " + bin(ROSTCLI_REFINE_T) +
                                  " -i words.csv -V 40 -K 4 --online --online.mint 1 --out.ppx.online '')");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err, "topics.refine.t: topics.online.csv: write error: File too large\n");
    const std::string topics = readText(dir + "/topics.online.csv");
    ASSERT_FALSE(topics.empty());
    EXPECT_EQ(topics.back(), '\n') << "half a line left: ..." << topics.substr(topics.size() - std::min<std::size_t>(topics.size(), 40));
    const auto rows = csv(dir + "/topics.online.csv");
    for (std::size_t d = 0; d < rows.size(); ++d) {
        EXPECT_EQ(rows[d][0], planted.stamp[d]) << "line " << d + 1;
        EXPECT_EQ(rows[d].size(), planted.words[d].size() + 1) << "line " << d + 1;
    }
}

// Out of memory reading an input whole (a file or standard input that never
// ends) is an error naming it, exit 2, not an abort. Under a 700 MB
// address-space limit (not under the sanitizers, whose shadow memory needs more).
TEST_F(RostCli, AnInputTooLargeForMemoryIsAnErrorNotAnAbort) {
#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
    GTEST_SKIP() << "an address-space limit and a sanitizer's shadow memory do not mix";
#else
    const struct {
        std::string cmd, err;
    } cases[] = {
        {bin(ROSTCLI_REFINE_T) + " -i /dev/zero -K 2 -n 1", "topics.refine.t: /dev/zero: out of memory reading it whole"},
        {bin(ROSTCLI_BINCOUNT) + " -V 3 < /dev/zero", "words.bincount: <stdin>: out of memory reading it whole"},
    };
    for (const auto& c : cases) {
        const Result r = run(dir, "(ulimit -v 700000; " + c.cmd + ")");
        EXPECT_EQ(r.status, 2) << c.cmd << ": " << r.err;
        EXPECT_EQ(r.err.rfind(c.err + ", after ", 0), 0u) << r.err;
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    }
#endif
}

} // namespace
