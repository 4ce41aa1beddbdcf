#include "Plot.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace avatar::servosim {

namespace {

std::string label(double v) {
    char text[32];
    std::snprintf(text, sizeof text, "%.4g", v);
    return text;
}

/// A "nice" tick step for a span.
double tickStep(double span, int ticks) {
    const double raw = span / std::max(1, ticks);
    const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
    for (double f : {1.0, 2.0, 5.0, 10.0}) {
        if (f * magnitude >= raw) return f * magnitude;
    }
    return 10.0 * magnitude;
}

void drawChart(cv::Mat& panel, const Chart& chart) {
    const int left = 80, right = 170, top = 30, bottom = 45;
    const cv::Rect plot(left, top, panel.cols - left - right, panel.rows - top - bottom);
    const cv::Scalar black(0, 0, 0), grey(210, 210, 210);
    const int font = cv::FONT_HERSHEY_SIMPLEX;

    std::size_t steps = 0;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const Series& s : chart.series) {
        steps = std::max(steps, s.y.size());
        for (double v : s.y) {
            if (std::isfinite(v)) {
                lo = std::min(lo, v);
                hi = std::max(hi, v);
            }
        }
    }
    if (!std::isfinite(lo)) {
        lo = 0.0;
        hi = 1.0;
    }
    if (hi - lo < 1e-9) {
        lo -= 1.0;
        hi += 1.0;
    }
    const double step = tickStep(hi - lo, 5);
    lo = std::floor(lo / step) * step;
    hi = std::ceil(hi / step) * step;
    const double xMax = std::max<double>(1.0, static_cast<double>(steps) - 1.0);
    const auto toPixel = [&](double x, double y) {
        return cv::Point(plot.x + static_cast<int>(std::lround(x / xMax * plot.width)),
                         plot.y + plot.height - static_cast<int>(std::lround((y - lo) / (hi - lo) * plot.height)));
    };

    for (double y = lo; y <= hi + step * 0.5; y += step) {
        const cv::Point a = toPixel(0, y);
        cv::line(panel, a, cv::Point(plot.x + plot.width, a.y), grey, 1);
        cv::putText(panel, label(y), cv::Point(8, a.y + 5), font, 0.4, black, 1, cv::LINE_AA);
    }
    const double xStep = tickStep(xMax, 10);
    for (double x = 0; x <= xMax + 1e-9; x += std::max(1.0, xStep)) {
        const cv::Point a = toPixel(x, lo);
        cv::line(panel, a, cv::Point(a.x, plot.y), grey, 1);
        cv::putText(panel, label(x), cv::Point(a.x - 6, a.y + 16), font, 0.4, black, 1, cv::LINE_AA);
    }
    cv::rectangle(panel, plot, black, 1);
    cv::putText(panel, chart.title, cv::Point(left, 20), font, 0.55, black, 1, cv::LINE_AA);
    cv::putText(panel, chart.xLabel, cv::Point(plot.x + plot.width / 2 - 30, panel.rows - 8), font, 0.45, black, 1,
                cv::LINE_AA);
    cv::putText(panel, chart.yLabel, cv::Point(8, 20), font, 0.45, black, 1, cv::LINE_AA);

    int legendY = top + 10;
    for (const Series& s : chart.series) {
        cv::Point previous(-1, -1);
        for (std::size_t i = 0; i < s.y.size(); ++i) {
            if (!std::isfinite(s.y[i])) {
                previous = cv::Point(-1, -1);
                continue;
            }
            const cv::Point p = toPixel(static_cast<double>(i), s.y[i]);
            if (previous.x >= 0) cv::line(panel, previous, p, s.colour, 2, cv::LINE_AA);
            cv::circle(panel, p, 3, s.colour, cv::FILLED, cv::LINE_AA);
            previous = p;
        }
        cv::line(panel, cv::Point(plot.x + plot.width + 12, legendY), cv::Point(plot.x + plot.width + 36, legendY),
                 s.colour, 2);
        cv::putText(panel, s.name, cv::Point(plot.x + plot.width + 42, legendY + 4), font, 0.42, black, 1,
                    cv::LINE_AA);
        legendY += 20;
    }
}

}  // namespace

cv::Mat drawCharts(const std::vector<Chart>& charts, int width, int panelHeight) {
    cv::Mat image(panelHeight * static_cast<int>(std::max<std::size_t>(1, charts.size())), width, CV_8UC3,
                  cv::Scalar(255, 255, 255));
    for (std::size_t i = 0; i < charts.size(); ++i) {
        cv::Mat panel = image(cv::Rect(0, static_cast<int>(i) * panelHeight, width, panelHeight));
        drawChart(panel, charts[i]);
    }
    return image;
}

}  // namespace avatar::servosim
