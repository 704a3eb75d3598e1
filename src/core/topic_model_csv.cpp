#include "rost/topic_model_csv.hpp"

#include <charconv>
#include <limits>

#include "rost/word_stream.hpp"

namespace rost {

std::string formatTopicModelCsv(const Model& model) {
    std::string out;
    out.reserve(static_cast<std::size_t>(model.K()) * static_cast<std::size_t>(model.V()) * 3);
    char buf[16];
    // The open topics in label order (all K without growth): row i is output topic i.
    for (int k = 0; k < model.K(); ++k) {
        if (!model.topicOpen(k)) continue;
        for (int v = 0; v < model.V(); ++v) {
            if (v) out.push_back(',');
            const auto r = std::to_chars(buf, buf + sizeof buf, model.topicWordCount(k, v));
            out.append(buf, r.ptr);
        }
        out.push_back('\n');
    }
    return out;
}

Status writeTopicModelCsv(const Model& model, const std::string& path) {
    return writeFileAtomic(path, formatTopicModelCsv(model));
}

Status parseTopicModelCsv(std::string_view text, int K, int V, std::vector<int32_t>& counts, std::string_view name) {
    if (K < 1 || V < 1) return Status::error(std::string(name) + ": K and V must be positive");
    const auto k = static_cast<std::size_t>(K), vocab = static_cast<std::size_t>(V);
    std::vector<int32_t> out(k * vocab, 0);
    auto where = [&](std::size_t line, std::size_t col) {
        return std::string(name) + ":" + std::to_string(line) + ":" + std::to_string(col) + ": ";
    };
    std::size_t pos = 0, lineNo = 0, topic = 0;
    while (pos < text.size()) {
        std::size_t end = text.find('\n', pos);
        if (end == std::string_view::npos) end = text.size();
        std::string_view line = text.substr(pos, end - pos);
        pos = end + 1;
        ++lineNo;
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        if (line.empty() || line.front() == '#') continue;
        if (topic >= k)
            return Status::error(where(lineNo, 1) + "more than K = " + std::to_string(K) + " topic lines");
        int64_t total = 0;
        std::size_t v = 0, at = 0;
        while (true) {
            std::size_t comma = line.find(',', at);
            if (comma == std::string_view::npos) comma = line.size();
            std::string_view f = line.substr(at, comma - at);
            std::size_t lead = 0;
            while (lead < f.size() && (f[lead] == ' ' || f[lead] == '\t')) ++lead;
            std::size_t trail = f.size();
            while (trail > lead && (f[trail - 1] == ' ' || f[trail - 1] == '\t')) --trail;
            const std::size_t col = at + lead + 1;
            f = f.substr(lead, trail - lead);
            if (f.empty()) {
                if (comma == line.size() && v > 0) break;  // a trailing comma
                return Status::error(where(lineNo, col) + "empty field");
            }
            if (v >= vocab)
                return Status::error(where(lineNo, col) + "more than V = " + std::to_string(V) + " counts");
            int64_t c = 0;
            const auto [ptr, ec] = std::from_chars(f.data(), f.data() + f.size(), c);
            if (ec == std::errc::result_out_of_range || (ec == std::errc() && ptr == f.data() + f.size() &&
                                                         (c < 0 || c > std::numeric_limits<int32_t>::max())))
                return Status::error(where(lineNo, col) + "count '" + std::string(f.substr(0, 24)) +
                                     "' out of range [0, 2^31)");
            if (ec != std::errc() || ptr != f.data() + f.size())
                return Status::error(where(lineNo, col) + "expected a count, found '" + std::string(f.substr(0, 24)) + "'");
            total += c;
            if (total > std::numeric_limits<int32_t>::max())
                return Status::error(where(lineNo, col) + "topic " + std::to_string(topic) +
                                     "'s total count exceeds 2^31 - 1");
            out[topic * vocab + v] = static_cast<int32_t>(c);
            ++v;
            if (comma == line.size()) break;
            at = comma + 1;
        }
        if (v != vocab)
            return Status::error(where(lineNo, 1) + std::to_string(v) + " counts, expected V = " + std::to_string(V));
        ++topic;
    }
    if (topic != k)
        return Status::error(std::string(name) + ": " + std::to_string(topic) + " topic lines, expected K = " +
                             std::to_string(K));
    counts = std::move(out);
    return {};
}

Status loadTopicModelCsv(const std::string& path, Model& model) {
    std::string text;
    if (Status st = readFile(path, text); !st.ok()) return st;
    std::vector<int32_t> counts;
    if (Status st = parseTopicModelCsv(text, model.K(), model.V(), counts, path); !st.ok()) return st;
    const auto V = static_cast<std::size_t>(model.V());
    for (int k = 0; k < model.K(); ++k) {
        int64_t total = model.topicCount(k);
        for (std::size_t v = 0; v < V; ++v) total += counts[static_cast<std::size_t>(k) * V + v];
        if (total > std::numeric_limits<int32_t>::max())
            return Status::error(path + ": topic " + std::to_string(k) +
                                 " would hold more than 2^31 - 1 words with the model's own counts");
    }
    if (Status st = model.addTopicCounts(counts); !st.ok()) return Status::error(path + ": " + st.message());
    return {};
}

} // namespace rost
