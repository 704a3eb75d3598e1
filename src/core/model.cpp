// rost::Model, the API (rost/model.hpp), over its implementation
// (src/core/model_core.hpp): each call goes to the ring store, refinement
// or measurements of the one ModelCore the Model owns.

#include "rost/model.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "model_core.hpp"

namespace rost {

const char* toString(AddError e) noexcept {
    switch (e) {
    case AddError::None: return "ok";
    case AddError::SizeMismatch: return "words and positions (or the given labels) differ in length";
    case AddError::WordOutOfRange: return "word id out of range";
    case AddError::PositionOutOfRange: return "position outside the frame";
    case AddError::LabelOutOfRange: return "initial label out of range";
    }
    return "unknown";
}

double LogLoss::perplexity() const noexcept {
    if (words == 0) return std::numeric_limits<double>::quiet_NaN();
    return std::exp(nll / static_cast<double>(words));
}

std::unique_ptr<Model> Model::create(const Config& config, Status& status) {
    status = config.validate();
    if (!status.ok()) return nullptr;
    return std::make_unique<Model>(config);
}

Model::Model(const Config& config) {
    const Status st = config.validate();
    if (!st.ok()) throw std::invalid_argument(st.message());
    core_ = std::make_unique<ModelCore>(config);
}

Model::~Model() = default;

const Config& Model::config() const noexcept { return core_->config(); }
int Model::K() const noexcept { return core_->K(); }
int Model::activeTopics() const noexcept { return core_->activeTopics(); }
uint64_t Model::growthMovesAccepted() const noexcept { return core_->growthMovesAccepted(); }
double Model::learnedGamma() const noexcept { return core_->learnedGamma(); }
bool Model::topicCapReached() const noexcept { return core_->topicCapReached(); }
bool Model::topicOpen(int k) const noexcept { return core_->topicOpen(k); }
void Model::outputNumbering(std::span<uint16_t> map) const noexcept { core_->outputNumbering(map); }
void Model::slotsInLabelOrder(std::span<uint16_t> slots) const noexcept {
    std::size_t i = 0;
    for (const bool open : {true, false})
        for (int k = 0; k < K() && i < slots.size(); ++k)
            if (topicOpen(k) == open) slots[i++] = static_cast<uint16_t>(k);
}
int Model::V() const noexcept { return core_->V(); }
int Model::cellsPerStep() const noexcept { return core_->cellsPerStep(); }
AddResult Model::addObservation(std::span<const uint32_t> words, std::span<const Position> positions) noexcept { return core_->addObservation(words, positions, {}); }
AddResult Model::addObservation(std::span<const uint32_t> words, std::span<const Position> positions,
                                std::span<const uint16_t> labels) noexcept {
    return core_->addObservation(words, positions, labels);
}
AddResult Model::validateObservation(std::span<const uint32_t> words, std::span<const Position> positions) const noexcept { return core_->validateObservation(words, positions); }
uint64_t Model::observations() const noexcept { return core_->observations(); }
int64_t Model::steps() const noexcept { return core_->steps(); }
int64_t Model::oldestStep() const noexcept { return core_->oldestStep(); }
bool Model::inWindow(int64_t step) const noexcept { return core_->inWindow(step); }
int64_t Model::stepOfObservation(uint64_t frame) const noexcept { return core_->stepOfObservation(frame); }
bool Model::observationInWindow(uint64_t frame) const noexcept { return core_->observationInWindow(frame); }
uint32_t Model::refineCell(int64_t step, int cell) noexcept { return core_->refineCell(step, cell); }
uint32_t Model::refineStep(int64_t step) noexcept { return core_->refineStep(step); }
uint64_t Model::refineAll(int sweeps) noexcept { return core_->refineAll(sweeps); }
uint64_t Model::refineAll(int sweeps, const std::atomic<bool>* stop) noexcept { return core_->refineAll(sweeps, stop); }
RefineCount Model::refine(StepPicker& picker, const RefineLimits& limits) noexcept { return core_->refine(picker, limits); }
int Model::threads() const noexcept { return core_->threads(); }
void Model::setThreads(int n) { core_->setThreads(n); }
void Model::applyWorkerSettings(const ThreadSettings& settings) { core_->applyWorkerSettings(settings); }
int Model::colours() const noexcept { return core_->colours(); }
int Model::colourStride() const noexcept { return core_->colourStride(); }
int Model::colourOf(int64_t step, int cell) const noexcept { return core_->colourOf(step, cell); }
uint64_t Model::tokensRefined() const noexcept { return core_->tokensRefined(); }
uint32_t Model::wordsInStep(int64_t step) const noexcept { return core_->wordsInStep(step); }
void Model::setKernelPath(kernel::Path p) noexcept { core_->setKernelPath(p); }
kernel::Path Model::kernelPath() const noexcept { return core_->kernelPath(); }
uint64_t Model::poolJobs() const noexcept { return core_->poolJobs(); }
LogLoss Model::cellLogLoss(int64_t step, int cell) const noexcept { return core_->cellLogLoss(step, cell); }
LogLoss Model::stepLogLoss(int64_t step) const noexcept { return core_->stepLogLoss(step); }
double Model::wordLogProb(int64_t step, int cell, uint32_t slot) const noexcept { return core_->wordLogProb(step, cell, slot); }
LogLoss Model::cellPluginLogLoss(int64_t step, int cell) const noexcept { return core_->cellPluginLogLoss(step, cell); }
LogLoss Model::stepPluginLogLoss(int64_t step) const noexcept { return core_->stepPluginLogLoss(step); }
double Model::observationSurprise(uint64_t frame) const noexcept { return core_->observationSurprise(frame); }
std::span<const float> Model::cellSurprise(int64_t step) const noexcept { return core_->cellSurprise(step); }
uint32_t Model::observationSize(uint64_t frame) const noexcept { return core_->observationSize(frame); }
void Model::observationWords(uint64_t frame, std::span<uint32_t> out) const noexcept { core_->observationWords(frame, out); }
void Model::observationPositions(uint64_t frame, std::span<Position> out) const noexcept { core_->observationPositions(frame, out); }
void Model::observationLabels(uint64_t frame, std::span<uint16_t> out) const noexcept { core_->observationLabels(frame, out); }
void Model::finalMeasurements(uint64_t first, std::span<double> perplexity, std::span<uint16_t> labels,
                              std::size_t stride) const noexcept { core_->finalMeasurements(first, perplexity, labels, stride); }
void Model::observationSamples(uint64_t frame, std::span<uint16_t> out) const noexcept { core_->observationSamples(frame, out); }
std::span<const int32_t> Model::cellHistogram(int64_t step, int cell) const noexcept { return core_->cellHistogram(step, cell); }
uint32_t Model::cellWordCount(int64_t step, int cell) const noexcept { return core_->cellWordCount(step, cell); }
int32_t Model::topicWordCount(int k, int v) const noexcept { return core_->topicWordCount(k, v); }
int32_t Model::topicCount(int k) const noexcept { return core_->topicCount(k); }
uint64_t Model::wordsInModel() const noexcept { return core_->wordsInModel(); }
Status Model::addTopicCounts(std::span<const int32_t> counts) { return core_->addTopicCounts(counts); }
bool Model::checkInvariants(std::string* why) const { return core_->checkInvariants(why); }
std::size_t Model::memoryBytes() const noexcept { return core_->memoryBytes(); }
Rng& Model::rng() noexcept { return core_->rng(); }
void Model::describeState(StateLayout& out) noexcept { core_->describeState(out); }
bool Model::checkRestoredState(StateProblem& problem) const { return core_->checkRestoredState(problem); }
void Model::stateRestored() noexcept { core_->stateRestored(); }

} // namespace rost
