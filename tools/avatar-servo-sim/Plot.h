#pragma once
/// @file Plot.h
/// Line charts for avatar-servo-sim's per-run PNGs (like thesis Figures
/// 6-3 to 6-5): one panel per chart stacked vertically, x the step index.

#include <opencv2/core/mat.hpp>

#include <string>
#include <vector>

namespace avatar::servosim {

struct Series {
    std::string name;
    std::vector<double> y;  ///< one value per step; NaN: no value at that step
    cv::Scalar colour;      ///< BGR
};

struct Chart {
    std::string title;
    std::string xLabel;
    std::string yLabel;
    std::vector<Series> series;
};

/// The charts drawn one above the other, @p width x (@p panelHeight per chart), 8-bit BGR.
cv::Mat drawCharts(const std::vector<Chart>& charts, int width = 900, int panelHeight = 300);

}  // namespace avatar::servosim
