#include <avatar/acquire/AcquireSIPFirewire.h>

#include "AvatarCameras.h"
#include "FirewireBus.h"

#include <opencv2/core.hpp>

#include <utility>

namespace avatar {

AcquireSIPFirewire::AcquireSIPFirewire(std::unique_ptr<FirewireBus> bus, FirewireOptions options,
                                       std::uint32_t groupSize, FirewireSleepFunction sleep)
    : AcquireStereoImagePair(groupSize),
      cameras_(std::make_unique<AvatarCameras>(std::move(bus), options, std::move(sleep))),
      zeroCopy_(options.zeroCopyViews) {}

AcquireSIPFirewire::~AcquireSIPFirewire() = default;

AcquisitionStatus AcquireSIPFirewire::status() const { return cameras_->status(); }

void AcquireSIPFirewire::configure(const AvatarConfig& config) { lastChange_ = cameras_->configure(config.camera); }

AcquiredPair AcquireSIPFirewire::grab() {
    const RawFramePair raw = cameras_->grabRawImagePair();
    const CameraHardwareConfig& camera = *cameras_->settings();

    PairLayout layout;
    layout.format = camera.channels == 3 ? PixelFormat::Bgr : camera.bayer ? PixelFormat::Bayer : PixelFormat::Mono;
    layout.bayerPattern = camera.bayerPattern;
    layout.bitDepth = camera.bitDepth;
    const int cvType = CV_MAKETYPE(camera.bitDepth <= 8 ? CV_8U : CV_16U, camera.channels);
    const cv::Size size(camera.width, camera.height);

    AcquisitionId id;
    id.left = {formatGuid(raw.leftGuid), raw.left.timestampUs};
    id.right = {formatGuid(raw.rightGuid), raw.right.timestampUs};

    AcquiredPair acquired;
    if (zeroCopy_ && camera.channels == 1 && raw.left.stride == raw.right.stride) {
        // Valid until the next grab gives the buffers back (see the header).
        acquired.pair = StereoImagePair::view(raw.left.data, raw.right.data, size, cvType, layout, raw.left.stride, id);
        return acquired;
    }
    const cv::Mat left(size, cvType, raw.left.data, raw.left.stride);
    const cv::Mat right(size, cvType, raw.right.data, raw.right.stride);
    cv::Mat leftCopy;
    cv::Mat rightCopy;
    if (camera.channels == 3) {
        // IIDC sends R, G, B; the pair holds B, G, R.
        leftCopy.create(size, cvType);
        rightCopy.create(size, cvType);
        const int fromTo[] = {0, 2, 1, 1, 2, 0};
        cv::mixChannels(&left, 1, &leftCopy, 1, fromTo, 3);
        cv::mixChannels(&right, 1, &rightCopy, 1, fromTo, 3);
    } else {
        leftCopy = left.clone();
        rightCopy = right.clone();
    }
    cameras_->releaseFrames();
    acquired.pair = StereoImagePair(std::move(leftCopy), std::move(rightCopy), layout, id);
    return acquired;
}

std::unique_ptr<AcquireSIPFirewire> makeFirewireAcquisition(FirewireOptions options, std::uint32_t groupSize) {
    return std::make_unique<AcquireSIPFirewire>(makeDc1394Bus(), options, groupSize);
}

}  // namespace avatar
