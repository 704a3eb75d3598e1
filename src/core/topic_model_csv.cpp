#include "rost/topic_model_csv.hpp"

#include <algorithm>
#include <limits>

#include "rost/text_io.hpp"

namespace rost {

std::string formatTopicModelCsv(const Model& model) {
    std::string out;
    out.reserve(static_cast<std::size_t>(model.K()) * static_cast<std::size_t>(model.V()) * 3);
    text::TableWriter table(out);
    // The open topics in label order (all K without growth): row i is output topic i.
    for (int k = 0; k < model.K(); ++k) {
        if (!model.topicOpen(k)) continue;
        for (int v = 0; v < model.V(); ++v) table.cell(model.topicWordCount(k, v));
        table.end();
    }
    return out;
}

Status writeTopicModelCsv(const Model& model, const std::string& path) {
    return text::writeFileAtomic(path, formatTopicModelCsv(model));
}

namespace {

// One topic's line: V counts into `row`, each in [0, 2^31), their total too.
Status parseTopicLine(const text::Line& line, std::string_view name, int V, std::size_t topic,
                      std::vector<text::Field>& fields, int32_t* row, std::size_t& columns) {
    using text::where;
    text::splitFields(line.text, ",", fields);
    int64_t total = 0;
    std::size_t v = 0;
    for (const text::Field& f : fields) {
        if (f.text.empty()) return Status::error(where(name, line.number, f.column) + "empty field");
        if (v >= static_cast<std::size_t>(V))
            return Status::error(where(name, line.number, f.column) + "more than V = " + std::to_string(V) + " counts");
        int64_t c = 0;
        const text::NumberError e = text::toInteger(f.text, c);
        if (e == text::NumberError::Overflow ||
            (e == text::NumberError::None && (c < 0 || c > std::numeric_limits<int32_t>::max())))
            return Status::error(where(name, line.number, f.column) + "count '" + std::string(f.text.substr(0, 24)) +
                                 "' out of range [0, 2^31)");
        if (e == text::NumberError::Syntax) return text::expected(name, line.number, f, "a count", 24);
        total += c;
        if (total > std::numeric_limits<int32_t>::max())
            return Status::error(where(name, line.number, f.column) + "topic " + std::to_string(topic) +
                                 "'s total count exceeds 2^31 - 1");
        row[v++] = static_cast<int32_t>(c);
    }
    // Every line as long as the first: a model of fewer words (another
    // mission's V) leaves the words past its lines at 0.
    if (topic == 0) columns = v;
    if (v != columns)
        return Status::error(where(name, line.number, 1) + std::to_string(v) + " counts, expected " +
                             std::to_string(columns) + " as on the first line");
    return {};
}

} // namespace

Status parseTopicModelCsv(std::string_view csv, int K, int V, std::vector<int32_t>& counts, std::string_view name) {
    if (K < 1 || V < 1) return Status::error(std::string(name) + ": K and V must be positive");
    const auto k = static_cast<std::size_t>(K), vocab = static_cast<std::size_t>(V);
    std::vector<int32_t> out(k * vocab, 0);
    std::vector<text::Field> fields;
    text::LineReader lines(text::withoutByteOrderMark(csv), name);
    text::Line line;
    std::size_t topic = 0, columns = 0;
    while (lines.next(line)) {
        if (topic >= k)
            return Status::error(text::where(name, line.number, 1) + "more than K = " + std::to_string(K) + " topic lines");
        if (Status st = parseTopicLine(line, name, V, topic, fields, out.data() + topic * vocab, columns); !st.ok())
            return st;
        ++topic;
    }
    // Up to K lines: a growth run's topicmodel.csv holds a line per topic open
    // at its end (A <= K); the topics past its lines start empty.
    if (topic == 0)
        return Status::error(std::string(name) + ": no topic lines (expected 1 to K = " + std::to_string(K) + ")");
    counts = std::move(out);
    return {};
}

TopicModelShape topicModelShapeOf(std::string_view csv, const std::string& name) {
    TopicModelShape shape;
    std::vector<text::Field> fields;
    text::LineReader lines(text::withoutByteOrderMark(csv), name);
    for (text::Line line; lines.next(line); ++shape.rows) {
        if (shape.rows > 0) continue;
        text::splitFields(line.text, ",", fields);
        shape.columns = static_cast<int>(std::min<std::size_t>(fields.size(), INT32_MAX));
    }
    return shape;
}

Status readTopicModelShape(const std::string& path, TopicModelShape& shape) {
    std::string csv;
    if (Status st = text::readFile(path, csv); !st.ok()) return st;
    shape = topicModelShapeOf(csv, path);
    return {};
}

Status loadTopicModelCsv(const std::string& path, Model& model) {
    std::string csv;
    if (Status st = text::readFile(path, csv); !st.ok()) return st;
    std::vector<int32_t> counts;
    if (Status st = parseTopicModelCsv(csv, model.K(), model.V(), counts, path); !st.ok()) return st;
    if (Status st = model.addTopicCounts(counts); !st.ok()) return Status::error(path + ": " + st.message());
    return {};
}

} // namespace rost
