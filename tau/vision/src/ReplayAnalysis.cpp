#include <avatar/tau/ReplayAnalysis.h>

#include <avatar/common/Error.h>

#include <utility>

namespace avatar {

ReplayAnalysis::ReplayAnalysis(const std::filesystem::path& session, std::optional<AvatarConfig> fixed,
                               std::filesystem::path configDirectory)
    : replay_(session),
      fixed_(fixed.has_value()),
      configDirectory_(fixed ? std::move(configDirectory) : session) {
    if (fixed) analyzer_ = std::make_unique<AnalyzeStereoImagePair>(*fixed, configDirectory_);
}

ReplayAnalysis::~ReplayAnalysis() = default;

bool ReplayAnalysis::finished() const { return replay_.status().state == AcquisitionStatus::State::Finished; }

void ReplayAnalysis::setParallel(bool parallel) {
    parallel_ = parallel;
    if (analyzer_) analyzer_->setParallel(parallel);
}

ReplayStep ReplayAnalysis::next() {
    ReplayStep step;
    try {
        step.acquired = replay_.acquire();
    } catch (const AcquisitionError& e) {
        step.damage = e.what();
        return step;
    }
    const AcquiredPair& acquired = *step.acquired;
    if (!fixed_ && acquired.recordedConfigXml) {
        analyzer_.reset();
        configProblem_.clear();
        try {
            analyzer_ = std::make_unique<AnalyzeStereoImagePair>(*acquired.recordedConfig(), configDirectory_);
            if (parallel_) analyzer_->setParallel(*parallel_);
        } catch (const Error& e) {
            configProblem_ = "configuration " + std::to_string(replay_.lastRecord()->configVersion) +
                             " cannot be used: " + e.what();
        }
    }
    if (!analyzer_) {
        step.failure = configProblem_;
        return step;
    }
    try {
        step.result = analyzer_->analyze(acquired.pair, step.iteration());
    } catch (const Error& e) {
        step.failure = std::string("analysis failed: ") + e.what();
    }
    return step;
}

VisionTargets ReplayAnalysis::analyzeAgain(const ReplayStep& step) {
    if (!step.result || !analyzer_)
        throw InvalidState("analyzeAgain: the step has no result to repeat (" +
                           (step.damaged() ? step.damage : step.failure) + ")");
    return analyzer_->analyze(step.acquired->pair, step.iteration());
}

}  // namespace avatar
