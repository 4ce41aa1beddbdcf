#include "Diagnose.h"

#include <avatar/common/CameraModel.h>
#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <fstream>

namespace avatar::calibrate {

namespace fs = std::filesystem;

namespace {

cv::Mat display(const LoadedImage& image) {
    cv::Mat out = toDisplay8(image.bgr, image.bitDepth);
    if (out.channels() == 1) cv::cvtColor(out, out, cv::COLOR_GRAY2BGR);
    return out;
}

nlohmann::json matrixJson(const cv::Mat& m) {
    cv::Mat d;
    m.convertTo(d, CV_64F);
    nlohmann::json rows = nlohmann::json::array();
    for (int i = 0; i < d.rows; ++i) {
        nlohmann::json row = nlohmann::json::array();
        for (int j = 0; j < d.cols; ++j) row.push_back(d.at<double>(i, j));
        rows.push_back(row);
    }
    return rows;
}

cv::Mat sideBySide(const cv::Mat& a, const cv::Mat& b) {
    cv::Mat out;
    cv::hconcat(a, b, out);
    return out;
}

void write(const fs::path& file, const cv::Mat& image) {
    if (!cv::imwrite(file.string(), image)) throw IoError("cannot write '" + file.string() + "'");
}

const cv::Scalar kColours[] = {{0, 0, 255}, {0, 200, 0}, {255, 80, 0}, {0, 200, 255}, {255, 0, 255}, {255, 255, 0}};

}  // namespace

nlohmann::json diagnose(const StereoSystemConfig& stereo, const LoadedImage& left, const LoadedImage& right,
                        const std::vector<cv::Point2d>& points, const fs::path& directory) {
    if (left.bgr.size() != right.bgr.size())
        throw InvalidArgument("--diagnose: the two images differ in size (" + left.name + ", " + right.name + ")");
    std::error_code ec;
    fs::create_directories(directory, ec);
    if (ec) throw IoError("cannot create '" + directory.string() + "': " + ec.message());
    const StereoGeometry g = stereoGeometry(stereo);
    const cv::Matx33d e = essentialMatrix(g.rightTLeft), f = fundamentalMatrix(g);
    const cv::Size size = left.bgr.size();

    // Epipolar curves: the line F p of the undistorted left point, walked in
    // undistorted right pixels and distorted back into the image.
    cv::Mat l = display(left), r = display(right);
    const cv::Matx33d kRight = cameraMatrix(stereo.right), kRightInv = kRight.inv();
    for (std::size_t i = 0; i < points.size(); ++i) {
        const cv::Scalar colour = kColours[i % 6];
        cv::drawMarker(l, cv::Point(cvRound(points[i].x), cvRound(points[i].y)), colour, cv::MARKER_CROSS, 21, 2);
        const cv::Point2d ideal = normalizedToPixel(stereo.left, normalizePixel(stereo.left, points[i]));
        const cv::Vec3d line = f * cv::Vec3d(ideal.x, ideal.y, 1.0);
        std::vector<cv::Point> curve;
        for (double x = -0.1 * size.width; x <= 1.1 * size.width; x += 4.0) {
            if (std::abs(line[1]) < 1e-12) break;
            const double y = -(line[0] * x + line[2]) / line[1];
            const cv::Vec3d n = kRightInv * cv::Vec3d(x, y, 1.0);
            const cv::Point2d px = normalizedToPixel(stereo.right, distortNormalized(stereo.right, {n[0], n[1]}));
            if (px.x >= -size.width && px.x <= 2 * size.width && px.y >= -size.height && px.y <= 2 * size.height)
                curve.emplace_back(cvRound(px.x), cvRound(px.y));
        }
        if (curve.size() >= 2) cv::polylines(r, curve, false, colour, 2, cv::LINE_AA);
    }
    write(directory / "epipolar.png", sideBySide(l, r));

    // The rectified pair.
    const cv::Mat kl(cameraMatrix(stereo.left)), kr(kRight);
    const cv::Mat dl = (cv::Mat_<double>(1, 5) << stereo.left.kc[0], stereo.left.kc[1], stereo.left.kc[2],
                        stereo.left.kc[3], stereo.left.kc[4]);
    const cv::Mat dr = (cv::Mat_<double>(1, 5) << stereo.right.kc[0], stereo.right.kc[1], stereo.right.kc[2],
                        stereo.right.kc[3], stereo.right.kc[4]);
    cv::Mat r1, r2, p1, p2, q;
    cv::stereoRectify(kl, dl, kr, dr, size, cv::Mat(rotationMatrix(g.rightTLeft)),
                      cv::Mat(translationVector(g.rightTLeft)), r1, r2, p1, p2, q, cv::CALIB_ZERO_DISPARITY, 0);
    cv::Mat mapLx, mapLy, mapRx, mapRy, rl, rr;
    cv::initUndistortRectifyMap(kl, dl, r1, p1, size, CV_32FC1, mapLx, mapLy);
    cv::initUndistortRectifyMap(kr, dr, r2, p2, size, CV_32FC1, mapRx, mapRy);
    cv::remap(display(left), rl, mapLx, mapLy, cv::INTER_LINEAR);
    cv::remap(display(right), rr, mapRx, mapRy, cv::INTER_LINEAR);
    cv::Mat rectified = sideBySide(rl, rr);
    for (int y = 24; y < size.height; y += 48)
        cv::line(rectified, {0, y}, {rectified.cols - 1, y}, cv::Scalar(0, 255, 0), 1, cv::LINE_AA);
    if (!points.empty()) {
        std::vector<cv::Point2d> in(points.begin(), points.end()), out;
        cv::undistortPoints(in, out, kl, dl, r1, p1);
        for (std::size_t i = 0; i < out.size(); ++i) {
            cv::drawMarker(rectified, cv::Point(cvRound(out[i].x), cvRound(out[i].y)), kColours[i % 6],
                           cv::MARKER_CROSS, 21, 2);
            cv::line(rectified, {0, cvRound(out[i].y)}, {rectified.cols - 1, cvRound(out[i].y)}, kColours[i % 6], 1,
                     cv::LINE_AA);
        }
    }
    write(directory / "rectified.png", rectified);

    nlohmann::json matrices;
    matrices["E"] = matrixJson(cv::Mat(e));
    matrices["F"] = matrixJson(cv::Mat(f));
    matrices["R1"] = matrixJson(r1);
    matrices["R2"] = matrixJson(r2);
    matrices["P1"] = matrixJson(p1);
    matrices["P2"] = matrixJson(p2);
    matrices["Q"] = matrixJson(q);
    matrices["note"] = "F maps undistorted left pixels to right epipolar lines (p_r^T F p_l = 0); E the same for "
                       "normalised coordinates; R1, R2, P1, P2, Q as cv::stereoRectify returns them (T in mm)";
    std::ofstream out(directory / "matrices.json", std::ios::trunc);
    out << matrices.dump(2) << "\n";
    if (!out) throw IoError("cannot write '" + (directory / "matrices.json").string() + "'");
    return matrices;
}

}  // namespace avatar::calibrate
