#pragma once

// A word stream extracted once from a piece of footage and cached on disk
// (data/experiment/<name>/): words.csv and positions.csv in the word-stream
// formats of rost/word_stream.hpp, and dataset.txt, key=value lines saying
// what the stream is (frame size, vocabulary size, source, extractor).

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "rost/config.hpp"
#include "rost/status.hpp"
#include "rost/word_stream.hpp"

namespace rost::experiment {

struct Dataset {
    std::string name;
    std::string dir;
    std::map<std::string, std::string> meta;  // dataset.txt as read
    int width = 0;
    int height = 0;
    uint32_t V = 0;
    std::vector<StreamObservation> frames;  // in stream order (one time step each)
    uint64_t words = 0;                     // over all frames
    uint32_t max_words_frame = 0;

    [[nodiscard]] int64_t steps() const noexcept { return static_cast<int64_t>(frames.size()); }
    [[nodiscard]] double wordsPerFrame() const noexcept {
        return frames.empty() ? 0.0 : static_cast<double>(words) / static_cast<double>(frames.size());
    }
};

// Reads DIR/dataset.txt, DIR/words.csv and DIR/positions.csv. `max_frames`
// > 0 keeps only the first frames. Errors name the file and line.
Status loadDataset(const std::string& dir, int64_t max_frames, Dataset& out);

// Writes dataset.txt (atomically) from key=value pairs, in the given order.
Status writeDatasetMeta(const std::string& dir, const std::vector<std::pair<std::string, std::string>>& kv);

// The model parameters the experiment takes from the settings (defaults:
// the schema's, the paper's section VII: 64 px cells one step wide, alpha
// 0.1, beta 0.5, K 16, 4 spatial + 2 temporal neighbours): K, alpha, beta,
// cell.space, g.space, g.time. `rost_experiment --set KEY=VALUE` changes them.
using ModelParams = Config;

// A Model configuration with `p`'s parameters that holds the whole stream in
// its window (no eviction: final perplexity is measured on every step) and
// never subsamples: the cell capacity is the largest number of words any
// cell receives, the frame capacity the largest frame.
Config modelConfig(const Dataset& d, const ModelParams& p, uint64_t seed);

} // namespace rost::experiment
