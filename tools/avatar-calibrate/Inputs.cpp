#include "Inputs.h"

#include <avatar/acquire/SessionLog.h>
#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>
#include <avatar/common/StereoImagePairFileIO.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <glob.h>

#include <algorithm>
#include <filesystem>

namespace avatar::calibrate {

std::vector<std::string> globFiles(const std::string& pattern) {
    glob_t matches{};
    const int rc = ::glob(pattern.c_str(), GLOB_ERR | GLOB_MARK, nullptr, &matches);
    std::vector<std::string> files;
    if (rc == 0)
        for (std::size_t i = 0; i < matches.gl_pathc; ++i) {
            const std::string f = matches.gl_pathv[i];
            if (!f.empty() && f.back() != '/') files.push_back(f);  // GLOB_MARK marks directories
        }
    ::globfree(&matches);
    if (files.empty()) throw IoError("no file matches '" + pattern + "'");
    std::sort(files.begin(), files.end());
    return files;
}

LoadedImage loadImage(const std::string& path) {
    LoadedImage out;
    out.name = path;
    const std::string extension = std::filesystem::path(path).extension().string();
    if (extension == ".raw") {
        const RawImageName name = RawImageName::parse(path);
        cv::Mat image = StereoImagePairFileIO::readRaw(path);
        out.bitDepth = name.geometry.bitDepth;
        out.bgr = name.geometry.format == PixelFormat::Bayer ? demosaic(image, name.geometry.bayerPattern) : image;
        return out;
    }
    if (!std::filesystem::exists(path)) throw IoError("image " + path + " does not exist");
    out.bgr = cv::imread(path, cv::IMREAD_UNCHANGED);
    if (out.bgr.empty()) throw FormatError("image " + path + " cannot be decoded");
    if (out.bgr.depth() != CV_8U && out.bgr.depth() != CV_16U)
        throw FormatError("image " + path + " is not 8- or 16-bit");
    if (out.bgr.channels() == 4) cv::cvtColor(out.bgr, out.bgr, cv::COLOR_BGRA2BGR);
    out.bitDepth = out.bgr.depth() == CV_16U ? 16 : 8;
    return out;
}

std::vector<std::pair<LoadedImage, LoadedImage>> loadSession(const std::string& directory,
                                                             std::vector<std::string>& skipped) {
    const SessionLogReader reader(directory);
    for (const std::string& e : reader.errors()) skipped.push_back(e);
    std::vector<std::pair<LoadedImage, LoadedImage>> pairs;
    for (const SessionRecord& record : reader.records()) {
        StereoImagePair pair;
        try {
            pair = reader.loadPair(record);
        } catch (const Error& e) {
            skipped.push_back(e.what());
            continue;
        }
        if (pair.layout().format == PixelFormat::Bayer) pair = demosaic(pair);
        LoadedImage l, r;
        l.name = (std::filesystem::path(directory) / record.files.left.name).string();
        r.name = (std::filesystem::path(directory) / record.files.right.name).string();
        l.bgr = pair.left();
        r.bgr = pair.right();
        l.bitDepth = r.bitDepth = pair.layout().bitDepth;
        pairs.emplace_back(std::move(l), std::move(r));
    }
    return pairs;
}

}  // namespace avatar::calibrate
