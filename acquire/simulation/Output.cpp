#include <avatar/render/Renderer.h>

#include <avatar/common/CameraModel.h>
#include <avatar/common/Error.h>
#include <avatar/common/StereoImagePairFileIO.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace avatar::render {

namespace {

std::string num(double value) {
    if (std::isnan(value)) return "nan";
    char buffer[40];
    for (int precision = 15; precision <= 17; ++precision) {
        std::snprintf(buffer, sizeof buffer, "%.*g", precision, value);
        if (std::strtod(buffer, nullptr) == value) break;
    }
    return buffer;
}

std::string point(const cv::Point3d& p) { return num(p.x) + " " + num(p.y) + " " + num(p.z); }
std::string point(const cv::Point2d& p) { return num(p.x) + " " + num(p.y); }

std::string escape(const std::string& s) {
    std::string out;
    for (char ch : s) {
        if (ch == '&') out += "&amp;";
        else if (ch == '<') out += "&lt;";
        else if (ch == '>') out += "&gt;";
        else if (ch == '"') out += "&quot;";
        else out += ch;
    }
    return out;
}

void writeView(std::ostringstream& out, const char* camera, const TargetView& v) {
    out << "    <view camera=\"" << camera << "\" visibility=\"" << toString(v.visibility)
        << "\" occluded=\"" << (v.occluded ? "true" : "false") << "\" atBorder=\""
        << (v.atBorder ? "true" : "false") << "\" cut=\"" << (v.cut ? "true" : "false") << "\" areaPx=\""
        << num(v.areaPx) << "\" potentialAreaPx=\"" << num(v.potentialAreaPx) << '"';
    if (v.cut) out << " outsideAreaPx=\"" << (std::isinf(v.outsideAreaPx) ? std::string("inf") : num(v.outsideAreaPx)) << '"';
    if (v.projectedCentrePx) out << " projectedCentrePx=\"" << point(*v.projectedCentrePx) << '"';
    if (v.silhouetteCentroidPx) out << " silhouetteCentroidPx=\"" << point(*v.silhouetteCentroidPx) << '"';
    out << "/>\n";
}

}  // namespace

std::string writeGroundTruthString(const GroundTruth& truth) {
    std::ostringstream out;
    out << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
        << "<groundTruth scene=\"" << escape(truth.sceneName) << "\" seed=\"" << truth.seed
        << "\" width=\"" << truth.width << "\" height=\"" << truth.height << "\" supersampling=\""
        << truth.supersampling << "\" adaptive=\"" << (truth.adaptive ? "true" : "false") << "\">\n";
    if (truth.baseTVision) {
        std::string rotation;
        for (double x : truth.baseTVision->rotation) rotation += (rotation.empty() ? "" : " ") + num(x);
        const auto& t = truth.baseTVision->translationMm;
        out << "  <registration rotation=\"" << rotation << "\" translationMm=\"" << num(t[0]) << ' '
            << num(t[1]) << ' ' << num(t[2]) << "\"/>\n";
    }
    for (const TargetTruth& t : truth.targets) {
        out << "  <target name=\"" << escape(t.name) << "\" type=\"" << escape(t.type) << "\" shape=\""
            << toString(t.shape) << "\" centreLeftMm=\"" << point(t.centreLeftMm) << "\" centreRightMm=\""
            << point(t.centreRightMm) << '"';
        if (t.centreBaseMm) out << " centreBaseMm=\"" << point(*t.centreBaseMm) << '"';
        out << ">\n";
        writeView(out, "left", t.left);
        writeView(out, "right", t.right);
        out << "  </target>\n";
    }
    if (truth.checkerboard) {
        const CheckerboardTruth& c = *truth.checkerboard;
        out << "  <checkerboard cornersX=\"" << c.cornersX << "\" cornersY=\"" << c.cornersY
            << "\" squareMm=\"" << num(c.squareMm) << "\">\n";
        for (std::size_t k = 0; k < c.cornersLeftMm.size(); ++k)
            out << "    <corner x=\"" << static_cast<int>(k) % c.cornersX << "\" y=\""
                << static_cast<int>(k) / c.cornersX << "\" leftMm=\"" << point(c.cornersLeftMm[k])
                << "\" leftPx=\"" << point(c.cornersLeftPx[k]) << "\" rightPx=\""
                << point(c.cornersRightPx[k]) << "\"/>\n";
        out << "  </checkerboard>\n";
    }
    const RenderStats& s = truth.stats;
    out << "  <stats milliseconds=\"" << num(s.milliseconds) << "\" pixels=\"" << s.pixels
        << "\" supersampledPixels=\"" << s.supersampledPixels << "\" rays=\"" << s.rays
        << "\" raysWithoutInverse=\"" << s.raysWithoutInverse << "\"/>\n";
    out << "</groundTruth>\n";
    return out.str();
}

void writeGroundTruthFile(const GroundTruth& truth, const std::filesystem::path& path) {
    const std::string text = writeGroundTruthString(truth);
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    if (!out || !(out << text) || !out.flush())
        throw IoError("cannot write ground-truth file '" + path.string() + "'");
}

WrittenFiles writeRender(const RenderResult& result, const SensorFormat& sensor,
                         const std::filesystem::path& directory, std::uint32_t group,
                         std::uint32_t member, bool previews) {
    std::error_code ec;
    std::filesystem::create_directories(directory, ec);
    if (ec) throw IoError("cannot create directory '" + directory.string() + "': " + ec.message());
    RawImageName name;
    name.group = group;
    name.member = member;
    name.geometry.width = sensor.width;
    name.geometry.height = sensor.height;
    name.geometry.bitDepth = sensor.bitDepth;
    name.geometry.format = sensor.format;
    name.geometry.bayerPattern = sensor.bayerPattern;
    name.geometry.byteOrder = sensor.fileByteOrder;

    WrittenFiles files;
    name.side = Side::Left;
    files.leftRaw = directory / name.str();
    StereoImagePairFileIO::writeRaw(files.leftRaw, result.pair.left(), name.geometry);
    name.side = Side::Right;
    files.rightRaw = directory / name.str();
    StereoImagePairFileIO::writeRaw(files.rightRaw, result.pair.right(), name.geometry);

    char stem[32];
    std::snprintf(stem, sizeof stem, "%05u_%05u", group, member);
    if (previews) {
        files.leftPreview = directory / ("L_" + std::string(stem) + ".png");
        files.rightPreview = directory / ("R_" + std::string(stem) + ".png");
        StereoImagePairFileIO::writeDisplay(files.leftPreview, result.pair.left(), result.pair.layout());
        StereoImagePairFileIO::writeDisplay(files.rightPreview, result.pair.right(), result.pair.layout());
    }
    files.groundTruth = directory / (std::string(stem) + "_truth.xml");
    writeGroundTruthFile(result.truth, files.groundTruth);
    return files;
}

}  // namespace avatar::render
