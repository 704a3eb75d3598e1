// Merging topic models into one global set (rost/merge.hpp; docs/fleet.md).
//
// The assignment is hand-written: Debian's solvers (dlib's
// max_cost_assignment, which takes integer costs; COIN-OR's LP and flow
// solvers) would make the core depend on a large library for sixty lines
// that solve matrices of at most K x K topics, K <= 1024.

#include "rost/merge.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "rost/checkpoint.hpp"
#include "rost/engine.hpp"
#include "rost/text_io.hpp"
#include "rost/topic_model_csv.hpp"

namespace rost {

Status MergeOptions::validate() const {
    auto number = [](double x) {
        std::string s;
        text::appendNumber(s, x);
        return s;
    };
    if (!(threshold >= 0.0 && threshold <= 1.0))
        return Status::error(threshold_name + " " + number(threshold) + " out of range [0, 1]");
    if (!(beta > 0.0 && beta <= 1e6)) return Status::error(beta_name + " " + number(beta) + " out of range (0, 1e6]");
    return {};
}

namespace {

// sqrt(phi_k(v)) of one topic over V words (row: its counts, words past
// row.size() count 0): the Hellinger distance is sqrt(|a - b|^2 / 2).
void sqrtPhi(std::span<const int64_t> row, int V, double beta, std::vector<double>& out) {
    double n = 0.0;
    for (int64_t c : row) n += static_cast<double>(c);
    const double norm = 1.0 / (n + V * beta);
    out.assign(static_cast<std::size_t>(V), std::sqrt(beta * norm));
    for (std::size_t v = 0; v < row.size() && v < out.size(); ++v)
        out[v] = std::sqrt((static_cast<double>(row[v]) + beta) * norm);
}

// H^2 = 1 - sum_v sqrt(p_v q_v) = sum_v (sqrt(p_v) - sqrt(q_v))^2 / 2 for two
// distributions. The second is summed: it is exactly 0 for one distribution,
// where 1 minus the first's sum leaves a rounding of about 1e-16 (H about
// 1e-8: a topic was not "identical" to itself at --threshold 0).
double distanceOf(const std::vector<double>& a, const std::vector<double>& b) {
    double sq = 0.0;
    for (std::size_t v = 0; v < a.size(); ++v) sq += (a[v] - b[v]) * (a[v] - b[v]);
    return std::sqrt(std::min(1.0, 0.5 * sq));
}

Status checkModel(const TopicCounts& m, std::size_t index) {
    const std::string what = "model " + std::to_string(index);
    if (m.K < 1 || m.V < 1) return Status::error(what + ": K and V must be at least 1");
    if (m.counts.size() != static_cast<std::size_t>(m.K) * static_cast<std::size_t>(m.V))
        return Status::error(what + ": " + std::to_string(m.counts.size()) + " counts, expected K x V = " +
                             std::to_string(static_cast<int64_t>(m.K) * m.V));
    // A count past what a topicmodel.csv holds would make its sum one too (and
    // sums of counts near 2^63 wrap): refused here, naming it.
    for (std::size_t i = 0; i < m.counts.size(); ++i)
        if (m.counts[i] < 0 || m.counts[i] > std::numeric_limits<int32_t>::max())
            return Status::error(what + ": count of topic " + std::to_string(i / static_cast<std::size_t>(m.V)) +
                                 ", word " + std::to_string(i % static_cast<std::size_t>(m.V)) +
                                 (m.counts[i] < 0 ? " is negative"
                                                  : " is " + std::to_string(m.counts[i]) +
                                                        ", more than a topic model file holds (2^31 - 1)"));
    return {};
}

// The global set while models join it.
struct Global {
    int V = 0;
    double beta = 0.0;
    std::vector<std::vector<int64_t>> rows;
    std::vector<std::vector<double>> root;  // sqrtPhi of each row

    int open(std::span<const int64_t> local) {
        rows.emplace_back(static_cast<std::size_t>(V), 0);
        root.emplace_back();
        add(static_cast<int>(rows.size()) - 1, local);
        return static_cast<int>(rows.size()) - 1;
    }
    void add(int g, std::span<const int64_t> local) {
        for (std::size_t v = 0; v < local.size(); ++v) rows[static_cast<std::size_t>(g)][v] += local[v];
    }
    void refresh(int g) { sqrtPhi(rows[static_cast<std::size_t>(g)], V, beta, root[static_cast<std::size_t>(g)]); }
};

// One model joins the global set: see rost/merge.hpp for the rule.
void join(const TopicCounts& m, const MergeOptions& o, Global& g, std::vector<int>& lift, std::vector<double>& dist) {
    lift.assign(static_cast<std::size_t>(m.K), -1);
    dist.assign(static_cast<std::size_t>(m.K), -1.0);
    std::vector<int> topics;  // the model's topics that hold a word
    std::vector<std::vector<double>> roots;
    for (int k = 0; k < m.K; ++k) {
        const std::span<const int64_t> row(m.counts.data() + static_cast<std::size_t>(k) * m.V, static_cast<std::size_t>(m.V));
        if (std::all_of(row.begin(), row.end(), [](int64_t c) { return c == 0; })) continue;
        topics.push_back(k);
        sqrtPhi(row, g.V, o.beta, roots.emplace_back());
    }
    const int rows = static_cast<int>(topics.size()), cols = static_cast<int>(g.rows.size());
    std::vector<double> cost(static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols));
    for (int r = 0; r < rows; ++r)
        for (int c = 0; c < cols; ++c)
            cost[static_cast<std::size_t>(r) * cols + c] = distanceOf(roots[static_cast<std::size_t>(r)], g.root[static_cast<std::size_t>(c)]);
    std::vector<int> assign = cols > 0 ? optimalAssignment(cost, rows, cols) : std::vector<int>(topics.size(), -1);
    std::vector<int> target(topics.size(), -1);  // the global topic each joins (as the set stood)
    for (int r = 0; r < rows; ++r) {
        const double* d = cost.data() + static_cast<std::size_t>(r) * cols;
        int best = assign[static_cast<std::size_t>(r)];
        if (best < 0 || d[best] > o.threshold) best = cols > 0 ? static_cast<int>(std::min_element(d, d + cols) - d) : -1;
        if (best >= 0 && d[best] <= o.threshold) {
            target[static_cast<std::size_t>(r)] = best;
            dist[static_cast<std::size_t>(topics[static_cast<std::size_t>(r)])] = d[best];
        }
    }
    std::vector<char> touched(g.rows.size(), 0);
    for (int r = 0; r < rows; ++r) {
        const int k = topics[static_cast<std::size_t>(r)];
        const std::span<const int64_t> row(m.counts.data() + static_cast<std::size_t>(k) * m.V, static_cast<std::size_t>(m.V));
        int t = target[static_cast<std::size_t>(r)];
        if (t >= 0) {
            g.add(t, row);
            touched[static_cast<std::size_t>(t)] = 1;
        } else {
            t = g.open(row);
            touched.push_back(1);
            dist[static_cast<std::size_t>(k)] = 0.0;
        }
        lift[static_cast<std::size_t>(k)] = t;
    }
    for (std::size_t t = 0; t < touched.size(); ++t)
        if (touched[t]) g.refresh(static_cast<int>(t));
}

} // namespace

double hellingerDistance(std::span<const int64_t> a, std::span<const int64_t> b, int V, double beta) {
    std::vector<double> ra, rb;
    sqrtPhi(a, V, beta, ra);
    sqrtPhi(b, V, beta, rb);
    return distanceOf(ra, rb);
}

Status mergeTopicModels(std::span<const TopicCounts> models, const MergeOptions& options, MergedTopics& out) {
    if (Status st = options.validate(); !st.ok()) return st;
    if (models.empty()) return Status::error("no topic models to merge");
    Global g;
    g.beta = options.beta;
    for (std::size_t i = 0; i < models.size(); ++i) {
        if (Status st = checkModel(models[i], i); !st.ok()) return st;
        g.V = std::max(g.V, models[i].V);
    }
    MergedTopics result;
    result.lifting.resize(models.size());
    result.distance.resize(models.size());
    for (std::size_t i = 0; i < models.size(); ++i) join(models[i], options, g, result.lifting[i], result.distance[i]);
    if (g.rows.empty()) return Status::error("the topic models hold no counts: no topic to merge");
    // What a topicmodel.csv holds (its readers: --in.topicmodel, rost merge):
    // a count below 2^31. A sum past it is refused, not written unreadable.
    for (std::size_t k = 0; k < g.rows.size(); ++k)
        for (std::size_t v = 0; v < g.rows[k].size(); ++v)
            if (g.rows[k][v] > std::numeric_limits<int32_t>::max())
                return Status::error("global topic " + std::to_string(k) + ", word " + std::to_string(v) + ": " +
                                     std::to_string(g.rows[k][v]) +
                                     " counts, more than a topic model file holds (2^31 - 1); merge fewer or smaller models");
    result.global.K = static_cast<int>(g.rows.size());
    result.global.V = g.V;
    for (const auto& row : g.rows) result.global.counts.insert(result.global.counts.end(), row.begin(), row.end());
    out = std::move(result);
    return {};
}

std::vector<int> optimalAssignment(std::span<const double> cost, int rows, int cols) {
    if (rows > cols) {  // assign the columns to the rows, then invert
        std::vector<double> t(cost.size());
        for (int r = 0; r < rows; ++r)
            for (int c = 0; c < cols; ++c) t[static_cast<std::size_t>(c) * rows + r] = cost[static_cast<std::size_t>(r) * cols + c];
        const std::vector<int> byCol = optimalAssignment(t, cols, rows);
        std::vector<int> assign(static_cast<std::size_t>(rows), -1);
        for (int c = 0; c < cols; ++c) assign[static_cast<std::size_t>(byCol[static_cast<std::size_t>(c)])] = c;
        return assign;
    }
    // Shortest augmenting paths with row and column potentials u, v (1-based
    // columns; column 0 is the row being placed): each row in turn is
    // placed, moving earlier rows along the cheapest alternating path.
    const double inf = std::numeric_limits<double>::infinity();
    std::vector<double> u(static_cast<std::size_t>(rows) + 1, 0.0), v(static_cast<std::size_t>(cols) + 1, 0.0);
    std::vector<int> owner(static_cast<std::size_t>(cols) + 1, 0), way(static_cast<std::size_t>(cols) + 1, 0);
    auto at = [&](int r, int c) { return cost[static_cast<std::size_t>(r - 1) * cols + static_cast<std::size_t>(c - 1)]; };
    for (int r = 1; r <= rows; ++r) {
        owner[0] = r;
        int free = 0;
        std::vector<double> slack(static_cast<std::size_t>(cols) + 1, inf);
        std::vector<char> used(static_cast<std::size_t>(cols) + 1, 0);
        do {
            used[static_cast<std::size_t>(free)] = 1;
            const int row = owner[static_cast<std::size_t>(free)];
            double delta = inf;
            int next = 0;
            for (int c = 1; c <= cols; ++c) {
                if (used[static_cast<std::size_t>(c)]) continue;
                const double reduced = at(row, c) - u[static_cast<std::size_t>(row)] - v[static_cast<std::size_t>(c)];
                if (reduced < slack[static_cast<std::size_t>(c)]) {
                    slack[static_cast<std::size_t>(c)] = reduced;
                    way[static_cast<std::size_t>(c)] = free;
                }
                if (slack[static_cast<std::size_t>(c)] < delta) {
                    delta = slack[static_cast<std::size_t>(c)];
                    next = c;
                }
            }
            for (int c = 0; c <= cols; ++c) {
                if (used[static_cast<std::size_t>(c)]) {
                    u[static_cast<std::size_t>(owner[static_cast<std::size_t>(c)])] += delta;
                    v[static_cast<std::size_t>(c)] -= delta;
                } else {
                    slack[static_cast<std::size_t>(c)] -= delta;
                }
            }
            free = next;
        } while (owner[static_cast<std::size_t>(free)] != 0);
        do {  // flip the path back to the start
            const int prev = way[static_cast<std::size_t>(free)];
            owner[static_cast<std::size_t>(free)] = owner[static_cast<std::size_t>(prev)];
            free = prev;
        } while (free != 0);
    }
    std::vector<int> assign(static_cast<std::size_t>(rows), -1);
    for (int c = 1; c <= cols; ++c)
        if (owner[static_cast<std::size_t>(c)] > 0) assign[static_cast<std::size_t>(owner[static_cast<std::size_t>(c)] - 1)] = c - 1;
    return assign;
}

Status readTopicCounts(const std::string& path, TopicCounts& out) {
    std::string bytes;
    if (Status st = text::readFile(path, bytes); !st.ok()) return st;
    if (bytes.starts_with("ROSTCKPT")) {
        Status status;
        std::unique_ptr<Engine> engine =  // the bytes already read: a FIFO can be read once only
            resumeEngine({reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()}, path, status);
        if (!engine) return status;
        const Model& m = engine->model();
        out = TopicCounts{};
        out.V = m.V();
        for (int k = 0; k < m.K(); ++k) {
            if (!m.topicOpen(k)) continue;
            ++out.K;
            for (int v = 0; v < m.V(); ++v) out.counts.push_back(m.topicWordCount(k, v));
        }
        // With growth only the open topics are kept (as its topicmodel.csv has them): none
        // when the model holds no word, which is named here, not as "model i: K ... 1".
        if (out.K == 0) return Status::error(path + ": a model with topics.grow that holds no word (no open topic)");
        return {};
    }
    const TopicModelShape shape = topicModelShapeOf(bytes, path);  // the file read once (a FIFO can be)
    if (shape.rows == 0 || shape.columns == 0) return Status::error(path + ": no topic lines");
    std::vector<int32_t> counts;
    if (Status st = parseTopicModelCsv(bytes, shape.rows, shape.columns, counts, path); !st.ok()) return st;
    out.K = shape.rows;
    out.V = shape.columns;
    out.counts.assign(counts.begin(), counts.end());
    return {};
}

std::string formatTopicCountsCsv(const TopicCounts& model) {
    std::string out;
    text::TableWriter table(out);
    for (int k = 0; k < model.K; ++k) {
        for (int v = 0; v < model.V; ++v) table.cell(model.at(k, v));
        table.end();
    }
    return out;
}

std::string formatLiftingCsv(const MergedTopics& merged, std::span<const std::string> names) {
    std::string out;
    text::TableWriter table(out);
    table.header({"model", "local", "global"});
    for (std::size_t m = 0; m < merged.lifting.size(); ++m)
        for (std::size_t k = 0; k < merged.lifting[m].size(); ++k) {
            if (m < names.size())
                table.cell(names[m]);
            else
                table.cell(static_cast<int64_t>(m));
            table.cell(static_cast<int64_t>(k));
            table.cell(static_cast<int64_t>(merged.lifting[m][k]));
            table.end();
        }
    return out;
}

} // namespace rost
