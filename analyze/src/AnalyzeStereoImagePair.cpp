#include <avatar/analyze/AnalyzeStereoImagePair.h>

#include "FrontEnd.h"
#include "RegionTracker.h"

#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>
#include <avatar/common/Logging.h>
#include <avatar/common/internal/WorkerThread.h>
#include <avatar/config/ConfigXml.h>

#include <log4cpp/Category.hh>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <set>

#include <time.h>

namespace avatar {
namespace {

/// The calling thread's CPU time, ms.
double threadCpuMs() {
    timespec t{};
    ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
}

}  // namespace

/// The right image's share of each stage runs on one long-lived thread.
class AnalyzeStereoImagePair::Worker : public detail::WorkerThread {};

AnalyzeStereoImagePair::AnalyzeStereoImagePair(const AvatarConfig& config,
                                               const std::filesystem::path& configDir,
                                               const StageRegistry& registry)
    : config_(config) {
    // The configuration's own rules first (ConfigError naming the element):
    // every stage below is built from validated values.
    validateConfig(config_);
    std::set<std::string, std::less<>> seen;
    const StageContext context{config_, configDir.string()};
    // A stage list the pipeline cannot build is the configuration's fault:
    // named at its element's line (docs/config.md).
    const std::string stagesPath = "/avatar/analysis/stages";
    for (const std::string& name : config_.analysis.stages) {
        if (!registry.contains(name)) {
            std::string known;
            for (const std::string& n : registry.names()) known += (known.empty() ? "" : ", ") + n;
            throw configErrorAt(config_, stagesPath, "unknown analysis stage '" + name + "' (known: " + known + ")");
        }
        std::unique_ptr<ProcessStereoImagePair> stage = registry.create(name, context);
        for (const std::string_view needed : stage->needs())
            if (!seen.count(needed))
                throw configErrorAt(config_, stagesPath,
                                    "analysis stage '" + name + "' needs '" + std::string(needed) + "' before it");
        seen.insert(name);
        stages_.push_back(std::move(stage));
        names_.push_back(name);
    }
    detail::fuseFrontEnd(stages_);
    parallel_ = config_.analysis.threads == 2;
    tracker_ = std::make_unique<detail::RegionTracker>(config_.analysis.tracking,
                                                      config_.analysis.coarseToFine.enabled);
    logging::category("analyze").info("pipeline: %zu stages, %zu target types", stages_.size(),
                                      config_.targets.targets.size());
}

AnalyzeStereoImagePair::~AnalyzeStereoImagePair() = default;

VisionTargets AnalyzeStereoImagePair::analyze(const StereoImagePair& pair, std::uint64_t iteration) {
    const auto& cam = config_.camera;
    if (pair.empty()) throw InvalidArgument("analyze: empty stereo pair");
    if (pair.size() != cv::Size(cam.width, cam.height))
        throw InvalidArgument("analyze: pair is " + std::to_string(pair.size().width) + "x" +
                              std::to_string(pair.size().height) + " but the camera configuration says " +
                              std::to_string(cam.width) + "x" + std::to_string(cam.height));
    if (pair.channels() != cam.channels)
        throw InvalidArgument("analyze: pair has " + std::to_string(pair.channels()) +
                              " channel(s) but the camera configuration says " + std::to_string(cam.channels));

    using Clock = std::chrono::steady_clock;
    const auto start = Clock::now();
    AnalysisFrame frame;
    frame.original = pair;
    frame.layout = pair.layout();
    for (Side side : {Side::Left, Side::Right}) frame.at(side).image = pair.image(side);
    frame.result.iteration = iteration;
    frame.result.acquisition = pair.id();
    frame.wholeImagesWanted = keepWholeImages_;
    frame.sidesInTurn = !parallel_;
    tracker_->begin(frame);

    // Consecutive stages whose sides are independent run as one batch: every
    // prepare(), then each side's image work of all of them in one task (one
    // fork and join for the batch, not one per stage), then every
    // processPair(). A stage's time is its preparation, its left image's work
    // (the right's too when serial), its pair work, and for the batch's last
    // stage with image work the wait for the right image. Its CPU time is
    // that of both threads for it.
    //
    // Each thread reads its clocks once per boundary between two pieces of
    // work and gives each piece the difference to the previous reading: the
    // thread's CPU clock is a system call (1.25 us on the 2-core VM), and two
    // readings per piece cost 6 % of a 0.3 MP frame (docs/benchmarks.md).
    struct Laps {
        Clock::time_point wall{Clock::now()};
        double cpu{threadCpuMs()};
        /// The time since the last boundary into @p wallMs (when given) and @p cpuMs.
        void to(double* wallMs, double& cpuMs) {
            const auto now = Clock::now();
            const double c = threadCpuMs();
            if (wallMs != nullptr) *wallMs += std::chrono::duration<double, std::milli>(now - wall).count();
            cpuMs += c - cpu;
            wall = now;
            cpu = c;
        }
    };
    std::vector<StageTiming> cpu;
    Laps laps;
    const double cpuStart = laps.cpu;
    double rightTotal = 0.0;  // the worker thread's CPU time
    for (std::size_t i = 0; i < stages_.size();) {
        std::size_t end = i + 1;
        if (stages_[i]->independentSides())
            while (end < stages_.size() && stages_[end]->independentSides()) ++end;
        std::vector<double> spent(end - i, 0.0), cpuSpent(end - i, 0.0), rightCpu(end - i, 0.0);
        std::size_t lastImageWork = end;
        for (std::size_t k = i; k < end; ++k) {
            stages_[k]->prepare(frame);
            laps.to(&spent[k - i], cpuSpent[k - i]);
            if (stages_[k]->hasImageWork()) lastImageWork = k;
        }
        if (lastImageWork != end) {
            const auto sideWork = [&](Side side, Laps& on, std::vector<double>* times, std::vector<double>& cpuTimes) {
                for (std::size_t k = i; k < end; ++k) {
                    if (!stages_[k]->hasImageWork()) continue;
                    stages_[k]->processImage(frame, side);
                    on.to(times != nullptr ? &(*times)[k - i] : nullptr, cpuTimes[k - i]);
                }
            };
            if (parallel_) {
                if (!worker_) worker_ = std::make_unique<Worker>();
                auto right = worker_->submit([&] {
                    Laps own;
                    sideWork(Side::Right, own, nullptr, rightCpu);
                });
                try {
                    sideWork(Side::Left, laps, &spent, cpuSpent);
                } catch (...) {
                    right.wait();  // never leave the worker writing into a dead frame
                    throw;
                }
                right.get();
                laps.to(&spent[lastImageWork - i], cpuSpent[lastImageWork - i]);
            } else {
                sideWork(Side::Left, laps, &spent, cpuSpent);
                sideWork(Side::Right, laps, &spent, cpuSpent);
            }
        }
        for (std::size_t k = i; k < end; ++k) {
            stages_[k]->processPair(frame);
            laps.to(&spent[k - i], cpuSpent[k - i]);
            frame.result.timings.push_back({std::string(stages_[k]->name()), spent[k - i]});
            cpu.push_back({std::string(stages_[k]->name()), cpuSpent[k - i] + rightCpu[k - i]});
            rightTotal += rightCpu[k - i];
        }
        i = end;
    }
    cpu.push_back({"total", laps.cpu - cpuStart + rightTotal});
    cpuTimings_ = std::move(cpu);
    frame.result.timings.push_back(
        {"total", std::chrono::duration<double, std::milli>(Clock::now() - start).count()});
    tracker_->end(frame);
    frame_ = std::move(frame);
    return frame_.result;
}

StereoImagePair AnalyzeStereoImagePair::workingImages(const AnalysisFrame& frame) {
    if (frame.original.empty()) return {};
    std::array<cv::Mat, 2> out;
    for (Side side : {Side::Left, Side::Right}) {
        if (!frame.imagesAroundFeatures) {
            out[side == Side::Left ? 0 : 1] = frame.at(side).image;
            continue;
        }
        // The fused front end's pass again, for the image alone.
        detail::FrontEndResult whole;
        detail::runFrontEnd(detail::imageInput(frame, side), whole);
        out[side == Side::Left ? 0 : 1] = whole.bgr;
    }
    PairLayout layout = frame.layout;
    layout.format = PixelFormat::Bgr;
    return StereoImagePair(out[0], out[1], layout, frame.original.id());
}

StereoImagePair AnalyzeStereoImagePair::filteredImages(const AnalysisFrame& frame) {
    if (frame.original.empty()) return {};
    const StereoImagePair images = workingImages(frame);
    std::array<cv::Mat, 2> out;
    for (Side side : {Side::Left, Side::Right}) {
        const ImageWork& w = frame.at(side);
        const cv::Mat& image = images.image(side);
        cv::Mat unionMask = cv::Mat::zeros(image.size(), CV_8UC1);
        for (const cv::Mat& m : w.masks) cv::bitwise_or(unionMask, m, unionMask);
        cv::Mat filtered = cv::Mat::zeros(image.size(), image.type());
        image.copyTo(filtered, unionMask);
        out[side == Side::Left ? 0 : 1] = filtered;
    }
    return StereoImagePair(out[0], out[1], frame.layout, frame.original.id());
}

StereoImagePair AnalyzeStereoImagePair::markedImages(const AnalysisFrame& frame) {
    if (frame.original.empty()) return {};
    static const cv::Scalar kColours[] = {{0, 255, 255}, {255, 0, 255}, {255, 255, 0},
                                          {0, 128, 255}, {255, 128, 0}, {128, 255, 0}};
    const StereoImagePair images = workingImages(frame);
    std::array<cv::Mat, 2> out;
    for (Side side : {Side::Left, Side::Right}) {
        const ImageWork& w = frame.at(side);
        cv::Mat display = toDisplay8(images.image(side), frame.layout.bitDepth);
        if (display.channels() == 1) cv::cvtColor(display, display, cv::COLOR_GRAY2BGR);
        for (std::size_t t = 0; t < w.features.size(); ++t) {
            const cv::Scalar colour = kColours[t % 6];
            for (const Feature& f : w.features[t]) {
                cv::rectangle(display, f.box, colour * 0.6, 1);
                for (const cv::Point& p : f.boundary) cv::circle(display, p, 2, colour, 1);
                cv::drawMarker(display, cv::Point(cvRound(f.weightedCentroid.x), cvRound(f.weightedCentroid.y)),
                               colour, cv::MARKER_CROSS, 9, 1);
            }
        }
        out[side == Side::Left ? 0 : 1] = display;
    }
    // Label matched targets with the same number in both images.
    int number = 0;
    for (const VisionTarget& t : frame.result.targets) {
        if (!(t.flags & kTargetStereo)) continue;
        const std::string label = t.type + " " + std::to_string(number++);
        if (t.centroidLeftPx)
            cv::putText(out[0], label, cv::Point(cvRound(t.centroidLeftPx->x) + 6, cvRound(t.centroidLeftPx->y) - 6),
                        cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255), 1);
        if (t.centroidRightPx)
            cv::putText(out[1], label, cv::Point(cvRound(t.centroidRightPx->x) + 6, cvRound(t.centroidRightPx->y) - 6),
                        cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255), 1);
    }
    return StereoImagePair(out[0], out[1], {PixelFormat::Bgr, BayerPattern::BG, 8}, frame.original.id());
}

}  // namespace avatar
