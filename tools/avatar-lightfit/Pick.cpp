#include "Pick.h"
#include "ToolDisplay.h"

#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>

#include <opencv2/core.hpp>
#include <opencv2/highgui.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdlib>
#include <optional>
#include <string>

namespace avatar::lightfit {
namespace {

constexpr const char* kWindow = "avatar-lightfit: left click light, then dark point; right click/u undo; Enter done";

struct PickState {
    std::vector<PointPair> pairs;
    std::optional<cv::Point2d> pendingLight;
    bool changed{true};
};

void onMouse(int event, int x, int y, int /*flags*/, void* data) {
    auto* state = static_cast<PickState*>(data);
    if (event == cv::EVENT_LBUTTONDOWN) {
        if (!state->pendingLight) {
            state->pendingLight = cv::Point2d(x, y);
        } else {
            state->pairs.push_back({*state->pendingLight, cv::Point2d(x, y), 0});
            state->pendingLight.reset();
        }
        state->changed = true;
    } else if (event == cv::EVENT_RBUTTONDOWN) {
        if (state->pendingLight) state->pendingLight.reset();
        else if (!state->pairs.empty()) state->pairs.pop_back();
        state->changed = true;
    }
}

/// The image stretched so that its 99.5th percentile of samples is white.
cv::Mat displayImage(const tools::WorkingImage& image) {
    cv::Mat display = toDisplay8(image.bgr, image.bitDepth);
    cv::Mat hist;
    const cv::Mat flat = display.reshape(1);
    const int channels[] = {0};
    const int bins[] = {256};
    const float range[] = {0.0f, 256.0f};
    const float* ranges[] = {range};
    cv::calcHist(&flat, 1, channels, cv::Mat(), hist, 1, bins, ranges);
    const double total = static_cast<double>(flat.total());
    double seen = 0.0;
    int top = 255;
    for (int i = 0; i < 256; ++i) {
        seen += hist.at<float>(i);
        if (seen >= 0.995 * total) {
            top = std::max(i, 1);
            break;
        }
    }
    display.convertTo(display, CV_8U, 255.0 / top);
    return display;
}

/// HighGUI (Qt) aborts the process when it cannot reach the display, so the
/// local X server's socket is tried first (ToolDisplay.h).
void requireDisplay() {
    const char* x = std::getenv("DISPLAY");
    const std::string display = x ? x : "";
    if (display.empty() && !std::getenv("WAYLAND_DISPLAY"))
        throw InvalidState("--pick needs a display (neither DISPLAY nor WAYLAND_DISPLAY is set); write the pairs "
                           "file by hand and give it with --pairs");
    // A local X server must answer; Wayland or a remote X server is left to HighGUI.
    if (const std::optional<std::string> socketPath = tools::unreachableLocalDisplay(display))
        throw InvalidState("--pick cannot reach the display DISPLAY=" + display + " (no X server at " + *socketPath +
                           ")");
}

}  // namespace

std::vector<PointPair> pickPairs(const tools::WorkingImage& image, cv::Point2d centre,
                                 const std::vector<PointPair>& start) {
    requireDisplay();
    const cv::Mat base = displayImage(image);
    PickState state;
    state.pairs = start;
    try {
        cv::namedWindow(kWindow, cv::WINDOW_NORMAL | cv::WINDOW_KEEPRATIO);
        // Whole on a 1400x900 screen area at most; the window can be resized and zoomed.
        const double scale = std::min({1.0, 1400.0 / base.cols, 900.0 / base.rows});
        cv::resizeWindow(kWindow, cvRound(base.cols * scale), cvRound(base.rows * scale));
        cv::setMouseCallback(kWindow, onMouse, &state);
        const cv::Scalar light(0, 230, 255), dark(255, 200, 0), white(255, 255, 255);
        for (;;) {
            if (state.changed) {
                cv::Mat view = base.clone();
                cv::drawMarker(view, centre, white, cv::MARKER_CROSS, 30, 2);
                for (const PointPair& p : state.pairs) {
                    cv::line(view, p.light, p.dark, white, 1, cv::LINE_AA);
                    cv::circle(view, p.light, 6, light, 2, cv::LINE_AA);
                    cv::circle(view, p.dark, 6, dark, 2, cv::LINE_AA);
                }
                if (state.pendingLight) cv::circle(view, *state.pendingLight, 6, light, 2, cv::LINE_AA);
                cv::putText(view,
                            std::to_string(state.pairs.size()) + " pairs" +
                                (state.pendingLight ? ", light point picked: click its dark point" : ""),
                            cv::Point(10, 30), cv::FONT_HERSHEY_SIMPLEX, 0.8, white, 2, cv::LINE_AA);
                cv::imshow(kWindow, view);
                state.changed = false;
            }
            const int key = cv::waitKey(30);
            if (key == 13 || key == 10 || key == ' ' || key == 'q' || key == 27) break;
            if (key == 'u') onMouse(cv::EVENT_RBUTTONDOWN, 0, 0, 0, &state);
            if (cv::getWindowProperty(kWindow, cv::WND_PROP_VISIBLE) < 1.0) break;
        }
        cv::destroyWindow(kWindow);
    } catch (const cv::Exception& e) {
        throw InvalidState(std::string("--pick cannot open a window: ") + e.what());
    }
    return state.pairs;
}

}  // namespace avatar::lightfit
