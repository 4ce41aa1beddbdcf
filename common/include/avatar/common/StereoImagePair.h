#pragma once
/// @file StereoImagePair.h
/// StereoImagePair (SIP): the left and right image of one acquisition, carried
/// together through the whole system (thesis 4.2.1).

#include <avatar/common/ImageFormat.h>

#include <opencv2/core/mat.hpp>

#include <cstddef>
#include <cstdint>
#include <string>

namespace avatar {

/// When and by which camera one image of a pair was taken.
struct CameraStamp {
    std::string cameraId;       ///< hardware id of the camera (as in CameraHardwareConfig)
    std::int64_t timestampUs{0};  ///< capture time, microseconds since the Unix epoch
    bool operator==(const CameraStamp& o) const { return cameraId == o.cameraId && timestampUs == o.timestampUs; }
};

/// Identity of an acquisition (thesis 4.2.2): the group number increments when
/// the configuration changes or the member number reaches the group size.
struct AcquisitionId {
    std::uint32_t group{0};
    std::uint32_t member{0};
    CameraStamp left;
    CameraStamp right;
    bool operator==(const AcquisitionId& o) const {
        return group == o.group && member == o.member && left == o.left && right == o.right;
    }
    bool operator!=(const AcquisitionId& o) const { return !(*this == o); }
};

/// Geometry and meaning of the pixels of both images of a pair.
struct PairLayout {
    PixelFormat format{PixelFormat::Bgr};
    BayerPattern bayerPattern{BayerPattern::BG};  ///< meaningful when format == Bayer
    int bitDepth{8};  ///< significant bits per sample: 1..8 in 8-bit, 9..16 in 16-bit containers
};

/// A left and a right image of equal size and type: 8 or 16 bits per sample,
/// 1 channel (mono or Bayer) or 3 channels (BGR).
///
/// A SIP either owns its pixels (reference-counted cv::Mat, shallow copies share
/// them as cv::Mat does) or is a view over memory it does not own, such as a
/// camera's DMA buffer; a view must not outlive that memory. clone() always
/// yields an owning deep copy.
class StereoImagePair {
public:
    /// An empty pair (no images).
    StereoImagePair() = default;

    /// Takes two images; throws avatar::InvalidArgument when they differ in size
    /// or type, are empty, or do not fit the layout (depth, channels, bit depth).
    StereoImagePair(cv::Mat left, cv::Mat right, PairLayout layout, AcquisitionId id = {});

    /// Wraps externally owned memory without copying. @p step is the row stride
    /// in bytes (0: tightly packed). Same checks as the constructor.
    static StereoImagePair view(void* leftData, void* rightData, cv::Size size, int cvType,
                                PairLayout layout, std::size_t step = 0, AcquisitionId id = {});

    bool empty() const { return left_.empty(); }
    const cv::Mat& left() const { return left_; }
    const cv::Mat& right() const { return right_; }
    const cv::Mat& image(Side side) const { return side == Side::Left ? left_ : right_; }
    /// Mutable access for in-place processing; size and type must not be changed.
    cv::Mat& image(Side side) { return side == Side::Left ? left_ : right_; }

    const PairLayout& layout() const { return layout_; }
    cv::Size size() const { return left_.size(); }
    int cvType() const { return left_.type(); }
    int channels() const { return left_.channels(); }
    /// 8 or 16: bits of the container type.
    int containerBits() const;

    const AcquisitionId& id() const { return id_; }
    void setId(const AcquisitionId& id) { id_ = id; }

    /// False for a view over external memory.
    bool ownsPixels() const { return owns_; }
    /// An owning deep copy (also of a view).
    StereoImagePair clone() const;

    /// One line for logs: "group 1 member 7, 1280x960 bayer BG 16-bit (owning)".
    std::string describe() const;

private:
    cv::Mat left_;
    cv::Mat right_;
    PairLayout layout_;
    AcquisitionId id_;
    bool owns_{true};
};

}  // namespace avatar
