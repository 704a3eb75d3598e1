#include "collector.hpp"

#include <cerrno>
#include <cstring>

#include "rost/word_stream.hpp"

namespace rost::tool {

Collector::Collector(Engine& engine, std::size_t slots) : records_(engine, slots) {}

Collector::~Collector() { (void)closeStreams(); }

std::string Collector::rejection() const {
    const MissionRejection& r = records_.rejection();
    if (!r.any) return {};
    return "frame " + std::to_string(r.timestamp) + ": the model rejected the observation (" + toString(r.error) +
           " at word " + std::to_string(r.index) + ")";
}

Status Collector::streamTo(OutputDir& out, bool words) {
    if (!records_.status().ok()) return records_.status();
    auto open = [&](Stream& s, const char* name) -> Status {
        s.path = out.staged(name);
        s.shown = out.dir() + "/" + name;
        s.file = std::fopen(s.path.c_str(), "wb");
        if (!s.file) return Status::error(s.path + ": cannot write: " + std::strerror(errno));
        out.track(name);
        return {};
    };
    Status st;
    if (words) {
        if (st = open(words_, "words.csv"); !st.ok()) return st;
        if (st = open(positions_, "positions.csv"); !st.ok()) return st;
    }
    if (st = open(topics_, "topics.csv"); !st.ok()) return st;
    // Only the files being written are formatted (`rost refine` writes topics.csv alone).
    records_.setFinalSink([this](const FinalLabels& f) { takeFinal(f); }, words);
    return {};
}

// The first file a write or its close failed for, named with its error.
Status Collector::closeStreams() {
    std::string failed;
    int error = 0;
    for (Stream* s : {&words_, &positions_, &topics_}) {
        if (!s->file) continue;
        const bool closed = std::fclose(s->file) == 0;
        if ((!closed || s->error != 0) && failed.empty()) failed = s->shown, error = s->error != 0 ? s->error : errno;
        s->file = nullptr;
    }
    if (!failed.empty()) return Status::error(failed + ": write failed: " + std::strerror(error));
    return {};
}

void Collector::takeFinal(const FinalLabels& f) {
    auto put = [&](Stream& s) {
        errno = 0;
        if (s.file && std::fwrite(line_.data(), 1, line_.size(), s.file) != line_.size() && s.error == 0)
            s.error = errno != 0 ? errno : EIO;
        line_.clear();
    };
    line_.clear();
    const int64_t frame = f.where.timestamp;
    if (words_.file) {
        appendCsvLine(line_, frame, f.words.data(), f.n);
        put(words_);
    }
    if (positions_.file) {
        appendPositionsLine(line_, frame, f.positions.data(), f.n);
        put(positions_);
    }
    appendCsvLine(line_, frame, f.labels.data(), f.n);
    put(topics_);
}

} // namespace rost::tool
