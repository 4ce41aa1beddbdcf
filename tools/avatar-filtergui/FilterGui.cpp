#include "FilterGui.h"

#include <avatar/analyze/ImageColorFilter.h>
#include <avatar/analyze/ImageFeatureLocator.h>
#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>
#include <avatar/common/Logging.h>
#include <avatar/config/ConfigXml.h>

#include <log4cpp/Category.hh>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <sstream>

namespace avatar::filtergui {
namespace {

constexpr double kOpen = 1e9;            ///< an open ratio max (ImageColorFilter.h: >= 65536 passes x/0)
constexpr double kOpenFrom = 65536.0;
constexpr int kRatioSteps = 402;         ///< 0, 0.01 .. 100 (401 positions), open
constexpr int kRatioOne = 201;           ///< the position of 1
constexpr int kAreaSteps = 601;          ///< 0, 1 .. 1e6 px
constexpr int kBrightnessSteps = 1000;

struct QuantityName {
    Quantity quantity;
    const char* name;
};
constexpr QuantityName kNames[] = {
    {Quantity::RedGreen, "rg"},         {Quantity::RedBlue, "rb"},       {Quantity::BlueGreen, "bg"},
    {Quantity::Brightness, "brightness"}, {Quantity::Hue, "hue"},        {Quantity::Saturation, "saturation"},
    {Quantity::Value, "value"},         {Quantity::Area, "area"},        {Quantity::AspectRatio, "aspectRatio"},
    {Quantity::AreaRatio, "areaRatio"}};

log4cpp::Category& logger() { return logging::category("filtergui"); }

double fullSum(int bitDepth) { return 3.0 * (std::ldexp(1.0, bitDepth) - 1.0); }

/// The range of @p q in @p type, for writing; an unset brightness is set to the whole scale first.
Range& rangeRef(TargetType& type, Quantity q, int bitDepth) {
    switch (q) {
        case Quantity::RedGreen: return type.redGreen;
        case Quantity::RedBlue: return type.redBlue;
        case Quantity::BlueGreen: return type.blueGreen;
        case Quantity::Brightness:
            if (!type.brightness) type.brightness = Range{0.0, fullSum(bitDepth)};
            return *type.brightness;
        case Quantity::Hue: return type.hsv.hue;
        case Quantity::Saturation: return type.hsv.saturation;
        case Quantity::Value: return type.hsv.value;
        case Quantity::Area: return type.area;
        case Quantity::AspectRatio: return type.aspectRatio;
        case Quantity::AreaRatio: return type.areaRatio;
    }
    throw InvalidArgument("unknown quantity");
}

bool isColourOf(Quantity q, ColorFilterMethod method) {
    const bool ratio = q == Quantity::RedGreen || q == Quantity::RedBlue || q == Quantity::BlueGreen ||
                       q == Quantity::Brightness;
    const bool hsv = q == Quantity::Hue || q == Quantity::Saturation || q == Quantity::Value;
    if (method == ColorFilterMethod::RgbRatio) return !hsv;
    return !ratio;
}

/// A decimal number, as a configuration writes one; nothing else.
std::optional<double> parseNumber(const std::string& text) {
    double v = 0.0;
    const char* first = text.data();
    const char* last = first + text.size();
    if (text.empty() || text.front() == '+') return std::nullopt;
    const auto [ptr, ec] = std::from_chars(first, last, v);
    if (ec != std::errc() || ptr != last || !std::isfinite(v)) return std::nullopt;
    return v;
}

/// @p v rounded to 3 significant digits, as the nearest double to the decimal.
double round3(double v) {
    if (!(v > 0.0)) return v;
    const int e = static_cast<int>(std::floor(std::log10(v)));
    if (e <= 2) {
        const double scale = std::pow(10.0, 2 - e);
        return std::round(v * scale) / scale;
    }
    const double scale = std::pow(10.0, e - 2);
    return std::round(v / scale) * scale;
}

std::string fmt(double v) {
    std::ostringstream s;
    if (v == std::floor(v) && std::fabs(v) < 1e7) {
        s << static_cast<long long>(v);
    } else {
        s.precision(4);
        s << v;
    }
    return s.str();
}

std::string rangeText(const Range& r, bool ratio) {
    const auto end = [&](double v) { return ratio && v >= kOpenFrom ? std::string("open") : fmt(v); };
    return end(r.min) + ".." + end(r.max);
}

void setPixel(cv::Mat& view, int x, int y, const cv::Scalar& colour) {
    if (x < 0 || y < 0 || x >= view.cols || y >= view.rows) return;
    view.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<std::uint8_t>(colour[0]), static_cast<std::uint8_t>(colour[1]),
                                         static_cast<std::uint8_t>(colour[2]));
}

/// The ring of @p width pixels just outside @p inner, clipped to @p view.
void drawFrame(cv::Mat& view, const cv::Rect& inner, int width, const cv::Scalar& colour) {
    for (int y = inner.y - width; y < inner.br().y + width; ++y)
        for (int x = inner.x - width; x < inner.br().x + width; ++x)
            if (!inner.contains(cv::Point(x, y))) setPixel(view, x, y, colour);
}

/// @p view where @p mask is set becomes half @p view, half @p tint.
void tint(cv::Mat& view, const cv::Mat& mask, const cv::Scalar& colour) {
    if (cv::countNonZero(mask) == 0) return;
    cv::Mat blended;
    cv::addWeighted(view, 0.5, cv::Mat(view.size(), view.type(), colour), 0.5, 0.0, blended);
    blended.copyTo(view, mask);
}

}  // namespace

std::string nameOf(Quantity q) {
    for (const QuantityName& n : kNames)
        if (n.quantity == q) return n.name;
    return "?";
}

Range rangeOf(const TargetType& type, Quantity q, int bitDepth) {
    TargetType copy = type;
    return rangeRef(copy, q, bitDepth);
}

void applyAssignment(TargetType& type, const std::string& assignment, int bitDepth) {
    const auto fail = [&](const std::string& problem) {
        return InvalidArgument("--set " + assignment + ": " + problem);
    };
    const std::size_t eq = assignment.find('=');
    if (eq == std::string::npos)
        throw fail("expected NAME.min=VALUE or NAME.max=VALUE (NAME: rg, rb, bg, brightness, hue, saturation, value, "
                   "area, aspectRatio, areaRatio), brightness=off, erodeRestore=true|false or erodeKernelSize=N");
    const std::string key = assignment.substr(0, eq), text = assignment.substr(eq + 1);
    if (key == "brightness") {
        if (text != "off") throw fail("brightness takes off (or set brightness.min / brightness.max)");
        if (type.filter != ColorFilterMethod::RgbRatio)
            throw fail("target type '" + type.name + "' uses the hsv filter, which has no brightness range");
        type.brightness.reset();
        return;
    }
    if (key == "erodeRestore") {
        if (text != "true" && text != "false") throw fail("expected true or false, got '" + text + "'");
        type.erodeRestore = text == "true";
        return;
    }
    if (key == "erodeKernelSize") {
        int n = 0;
        const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), n);
        if (text.empty() || ec != std::errc() || ptr != text.data() + text.size())
            throw fail("expected an integer, got '" + text + "'");
        type.erodeKernelSize = n;
        return;
    }
    const std::size_t dot = key.rfind('.');
    const std::string name = dot == std::string::npos ? key : key.substr(0, dot);
    const std::string end = dot == std::string::npos ? std::string() : key.substr(dot + 1);
    const QuantityName* found = nullptr;
    for (const QuantityName& n : kNames)
        if (name == n.name) found = &n;
    if (!found) throw fail("unknown range '" + name + "'");
    if (end != "min" && end != "max") throw fail("expected " + name + ".min or " + name + ".max");
    if (!isColourOf(found->quantity, type.filter))
        throw fail("target type '" + type.name + "' uses the " +
                   (type.filter == ColorFilterMethod::Hsv ? "hsv" : "rgb_ratio") + " filter, which has no " + name +
                   " range");
    const std::optional<double> v = parseNumber(text);
    if (!v) throw fail("expected a decimal number, got '" + text + "'");
    Range& r = rangeRef(type, found->quantity, bitDepth);
    (end == "min" ? r.min : r.max) = *v;
    logger().debugStream() << "--set " << assignment << ": " << name << " now " << r.min << ".." << r.max;
}

std::vector<Slider> slidersFor(const TargetType& type) {
    std::vector<Slider> s;
    const auto pair = [&](Quantity q, const std::string& label, SliderScale scale, int count) {
        s.push_back({label + " min", q, false, scale, count});
        s.push_back({label + " max", q, true, scale, count});
    };
    if (type.filter == ColorFilterMethod::RgbRatio) {
        pair(Quantity::RedGreen, "rg", SliderScale::Ratio, kRatioSteps);
        pair(Quantity::RedBlue, "rb", SliderScale::Ratio, kRatioSteps);
        pair(Quantity::BlueGreen, "bg", SliderScale::Ratio, kRatioSteps);
        pair(Quantity::Brightness, "brightness", SliderScale::Brightness, kBrightnessSteps);
    } else {
        pair(Quantity::Hue, "hue", SliderScale::Degrees, 360);
        pair(Quantity::Saturation, "saturation", SliderScale::Unit, 100);
        pair(Quantity::Value, "value", SliderScale::Unit, 100);
    }
    s.push_back({"area min", Quantity::Area, false, SliderScale::Area, kAreaSteps});
    return s;
}

double sliderValue(const Slider& slider, int position, int bitDepth) {
    const int p = std::clamp(position, 0, slider.count);
    switch (slider.scale) {
        case SliderScale::Ratio:
            if (p == 0) return 0.0;
            if (p >= kRatioSteps) return kOpen;
            return round3(std::pow(10.0, (p - kRatioOne) / 100.0));
        case SliderScale::Brightness: return std::round(p * fullSum(bitDepth) / kBrightnessSteps);
        case SliderScale::Degrees: return p;
        case SliderScale::Unit: return p / 100.0;
        case SliderScale::Area: {
            if (p == 0) return 0.0;
            const double v = std::pow(10.0, (p - 1) / 100.0);
            return v < 1000.0 ? std::round(v) : round3(v);
        }
    }
    return 0.0;
}

int sliderPosition(const Slider& slider, const TargetType& type, int bitDepth) {
    if (slider.quantity == Quantity::Brightness && !type.brightness) return slider.max ? slider.count : 0;
    const Range r = rangeOf(type, slider.quantity, bitDepth);
    const double v = slider.max ? r.max : r.min;
    int p = 0;
    switch (slider.scale) {
        case SliderScale::Ratio:
            if (v <= 0.0) p = 0;
            else if (v >= kOpenFrom) p = kRatioSteps;
            else p = std::clamp(static_cast<int>(std::lround(100.0 * std::log10(v))) + kRatioOne, 1, kRatioSteps - 1);
            break;
        case SliderScale::Brightness:
            p = static_cast<int>(std::lround(std::min(v, fullSum(bitDepth)) * kBrightnessSteps / fullSum(bitDepth)));
            break;
        case SliderScale::Degrees: p = static_cast<int>(std::lround(std::min(v, 360.0))); break;
        case SliderScale::Unit: p = static_cast<int>(std::lround(std::min(v, 1.0) * 100.0)); break;
        case SliderScale::Area:
            if (v <= 0.0) p = 0;
            else if (v < 1.0) p = 1;
            else p = static_cast<int>(std::min<long>(std::lround(100.0 * std::log10(std::min(v, 1e7))) + 1, kAreaSteps));
            break;
    }
    return std::clamp(p, 0, slider.count);
}

void applySlider(TargetType& type, const Slider& slider, int position, int bitDepth) {
    const double v = sliderValue(slider, position, bitDepth);
    Range& r = rangeRef(type, slider.quantity, bitDepth);
    const bool wraps = slider.quantity == Quantity::Hue;
    if (slider.max) {
        r.max = v;
        if (!wraps && r.min > v) r.min = v;
    } else {
        r.min = v;
        if (!wraps && r.max < v) r.max = v;
    }
    logger().debugStream() << "slider " << slider.label << " at " << position << ": " << nameOf(slider.quantity) << " "
                        << r.min << ".." << r.max;
}

Analysis analyse(const tools::WorkingImage& image, const TargetType& type, const AnalysisConfig& analysis) {
    Analysis a;
    std::vector<cv::Mat> masks;
    colorFilterMasks(image.bgr, image.bitDepth, {type}, masks);
    a.mask = masks.at(0);
    const bool erodeStage =
        std::find(analysis.stages.begin(), analysis.stages.end(), "erode_restore") != analysis.stages.end();
    a.kept = erodeStage && type.erodeRestore ? erodeRestore(a.mask, type.erodeKernelSize) : a.mask;
    const cv::Rect window = searchWindow(type, image.bgr.size());
    const cv::Mat intensity = analysis.centroid == CentroidMode::IntensityWeighted ? image.bgr : cv::Mat();
    a.features = locateFeatures(a.kept, intensity, type, window);
    a.passing = cv::countNonZero(a.mask);
    a.keptPixels = cv::countNonZero(a.kept);
    cv::Mat labels;
    a.components = cv::connectedComponents(a.kept(window), labels, 8, CV_32S) - 1;
    return a;
}

double defaultScale(cv::Size image) {
    if (image.width <= 0 || image.height <= 0) return 1.0;
    return std::min({1.0, 1024.0 / image.width, 768.0 / image.height});
}

cv::Point viewPoint(cv::Point2d p, double scale) {
    return {static_cast<int>(std::lround((p.x + 0.5) * scale - 0.5)),
            static_cast<int>(std::lround((p.y + 0.5) * scale - 0.5))};
}

cv::Rect viewBox(const cv::Rect& box, double scale) {
    const int x0 = static_cast<int>(std::floor(box.x * scale)), y0 = static_cast<int>(std::floor(box.y * scale));
    const int x1 = static_cast<int>(std::ceil((box.x + box.width) * scale));
    const int y1 = static_cast<int>(std::ceil((box.y + box.height) * scale));
    return {x0, y0, x1 - x0, y1 - y0};
}

std::string countsText(const TargetType& type, const Analysis& analysis) {
    std::ostringstream s;
    s << type.name << ": " << analysis.passing << " px pass";
    if (analysis.keptPixels != analysis.passing) s << ", " << analysis.keptPixels << " kept by erode-restore";
    s << "; " << analysis.features.size() << (analysis.features.size() == 1 ? " feature" : " features") << " (of "
      << analysis.components << (analysis.components == 1 ? " component)" : " components)");
    return s.str();
}

std::string rangesText(const TargetType& type) {
    std::ostringstream s;
    if (type.filter == ColorFilterMethod::RgbRatio) {
        s << "rg " << rangeText(type.redGreen, true) << "  rb " << rangeText(type.redBlue, true) << "  bg "
          << rangeText(type.blueGreen, true) << "  brightness "
          << (type.brightness ? rangeText(*type.brightness, false) : std::string("any"));
        if (!type.brightnessBands.empty()) s << "  (+" << type.brightnessBands.size() << " bands)";
    } else {
        s << "hue " << rangeText(type.hsv.hue, false) << "  saturation " << rangeText(type.hsv.saturation, false)
          << "  value " << rangeText(type.hsv.value, false);
    }
    s << "  area " << rangeText(type.area, false);
    return s.str();
}

cv::Mat renderView(const tools::WorkingImage& image, const TargetType& type, const Analysis& analysis,
                   double scale, const std::string& message) {
    if (!(scale > 0.0)) throw InvalidArgument("view scale must be > 0, got " + fmt(scale));
    cv::Mat full = toDisplay8(image.bgr, image.bitDepth);
    tint(full, analysis.kept, kTintKept);
    tint(full, analysis.mask & ~analysis.kept, kTintDropped);
    const cv::Size size(std::max(1, static_cast<int>(std::lround(full.cols * scale))),
                        std::max(1, static_cast<int>(std::lround(full.rows * scale))));
    cv::Mat view(size.height + kStatusHeight, size.width, CV_8UC3, cv::Scalar(32, 32, 32));
    cv::Mat picture = view(cv::Rect(0, 0, size.width, size.height));
    if (size == full.size()) full.copyTo(picture);
    else cv::resize(full, picture, size, 0, 0, scale < 1.0 ? cv::INTER_AREA : cv::INTER_NEAREST);
    if (!type.window.wholeImage()) {
        const cv::Rect w = viewBox(searchWindow(type, image.bgr.size()), scale);
        cv::rectangle(picture, w, kWindowColour, 1);
    }
    for (const Feature& f : analysis.features) {
        const cv::Point c = viewPoint(f.weightedCentroid, scale);
        for (int d = -kCrossArm; d <= kCrossArm; ++d) {
            setPixel(picture, c.x + d, c.y, kCrossColour);
            setPixel(picture, c.x, c.y + d, kCrossColour);
        }
    }
    for (const Feature& f : analysis.features) drawFrame(picture, viewBox(f.box, scale), kFrameWidth, kBoxColour);
    const cv::Scalar text(230, 230, 230);
    const int font = cv::FONT_HERSHEY_SIMPLEX;
    cv::putText(view, countsText(type, analysis), {6, size.height + 18}, font, 0.45, text, 1, cv::LINE_AA);
    cv::putText(view, rangesText(type), {6, size.height + 39}, font, 0.45, text, 1, cv::LINE_AA);
    cv::putText(view, message, {6, size.height + 60}, font, 0.45, text, 1, cv::LINE_AA);
    return view;
}

bool saveType(const TargetType& type, const std::filesystem::path& source, const std::filesystem::path& destination) {
    namespace fs = std::filesystem;
    const bool intoDestination = fs::exists(destination);
    AvatarConfig config = readConfigFile(intoDestination ? destination : source);
    if (!intoDestination && !config.lighting.templateImagePath.empty()) {
        const fs::path stored = config.lighting.templateImagePath;
        const fs::path from = fs::absolute(source).parent_path().lexically_normal();
        const fs::path to = fs::absolute(destination).parent_path().lexically_normal();
        if (stored.is_relative() && from != to) {
            config.lighting.templateImagePath = fs::absolute(resolveConfigPath(source, stored)).lexically_normal().string();
            logger().noticeStream() << "the lighting template is now " << config.lighting.templateImagePath << " (saved to "
                                 << destination.string() << ", away from " << source.string() << ")";
        }
    }
    bool replaced = false;
    for (TargetType& t : config.targets.targets)
        if (t.name == type.name) {
            t = type;
            replaced = true;
        }
    if (!replaced) config.targets.targets.push_back(type);
    writeConfigFile(config, destination);
    logger().infoStream() << (replaced ? "replaced" : "added") << " target type '" << type.name << "' in "
                       << destination.string();
    return replaced;
}

}  // namespace avatar::filtergui
