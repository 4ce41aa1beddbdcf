#include <avatar/common/Error.h>
#include <avatar/common/StereoImagePair.h>

#include <opencv2/core.hpp>

#include <sstream>

namespace avatar {
namespace {

std::string typeName(const cv::Mat& m) {
    std::ostringstream s;
    s << (m.depth() == CV_8U ? "8U" : m.depth() == CV_16U ? "16U" : "depth " + std::to_string(m.depth()))
      << "C" << m.channels();
    return s.str();
}

void checkImages(const cv::Mat& left, const cv::Mat& right, const PairLayout& layout) {
    if (left.empty() || right.empty())
        throw InvalidArgument("StereoImagePair: " + std::string(left.empty() ? "left" : "right") +
                              " image is empty");
    if (left.size() != right.size())
        throw InvalidArgument("StereoImagePair: left image is " + std::to_string(left.cols) + "x" +
                              std::to_string(left.rows) + " but right is " +
                              std::to_string(right.cols) + "x" + std::to_string(right.rows));
    if (left.type() != right.type())
        throw InvalidArgument("StereoImagePair: left image type " + typeName(left) +
                              " differs from right " + typeName(right));
    if (left.depth() != CV_8U && left.depth() != CV_16U)
        throw InvalidArgument("StereoImagePair: unsupported sample type " + typeName(left) +
                              " (8 or 16 bit unsigned only)");
    const int wantChannels = layout.format == PixelFormat::Bgr ? 3 : 1;
    if (left.channels() != wantChannels)
        throw InvalidArgument("StereoImagePair: format " + std::string(toString(layout.format)) +
                              " needs " + std::to_string(wantChannels) + " channel(s), images have " +
                              std::to_string(left.channels()));
    const int container = left.depth() == CV_8U ? 8 : 16;
    if (layout.bitDepth < 1 || layout.bitDepth > container)
        throw InvalidArgument("StereoImagePair: bit depth " + std::to_string(layout.bitDepth) +
                              " does not fit a " + std::to_string(container) + "-bit container");
    // One rule for every layer: up to 8 significant bits live in 8-bit samples,
    // 9 to 16 in 16-bit samples (raw file names rely on it).
    if (container == 16 && layout.bitDepth <= 8)
        throw InvalidArgument("StereoImagePair: bit depth " + std::to_string(layout.bitDepth) +
                              " belongs in an 8-bit container, not 16-bit");
}

}  // namespace

StereoImagePair::StereoImagePair(cv::Mat left, cv::Mat right, PairLayout layout, AcquisitionId id)
    : left_(std::move(left)), right_(std::move(right)), layout_(layout), id_(std::move(id)) {
    checkImages(left_, right_, layout_);
}

StereoImagePair StereoImagePair::view(void* leftData, void* rightData, cv::Size size, int cvType,
                                      PairLayout layout, std::size_t step, AcquisitionId id) {
    if (leftData == nullptr || rightData == nullptr)
        throw InvalidArgument("StereoImagePair::view: null " +
                              std::string(leftData == nullptr ? "left" : "right") + " buffer");
    if (size.width <= 0 || size.height <= 0)
        throw InvalidArgument("StereoImagePair::view: bad size " + std::to_string(size.width) + "x" +
                              std::to_string(size.height));
    const std::size_t rowStep = step == 0 ? static_cast<std::size_t>(cv::Mat::AUTO_STEP) : step;
    StereoImagePair pair(cv::Mat(size, cvType, leftData, rowStep),
                         cv::Mat(size, cvType, rightData, rowStep), layout, std::move(id));
    pair.owns_ = false;
    return pair;
}

int StereoImagePair::containerBits() const { return left_.depth() == CV_16U ? 16 : 8; }

StereoImagePair StereoImagePair::clone() const {
    StereoImagePair copy;
    copy.left_ = left_.clone();
    copy.right_ = right_.clone();
    copy.layout_ = layout_;
    copy.id_ = id_;
    copy.owns_ = true;
    return copy;
}

std::string StereoImagePair::describe() const {
    if (empty()) return "empty pair";
    std::ostringstream s;
    s << "group " << id_.group << " member " << id_.member << ", " << left_.cols << "x" << left_.rows
      << " " << toString(layout_.format);
    if (layout_.format == PixelFormat::Bayer) s << " " << toString(layout_.bayerPattern);
    s << " " << layout_.bitDepth << "-bit (" << (owns_ ? "owning" : "view") << ")";
    return s.str();
}

}  // namespace avatar
