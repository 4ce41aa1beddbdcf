#pragma once
/// @file Pick.h
/// avatar-lightfit --pick: the thesis's point picking (Figure 3-3) in a
/// HighGUI window. Part of the program only (not of the avatar_lightfit
/// library), built when OpenCV's highgui module is present.

#include "LightFit.h"

#include <vector>

namespace avatar::lightfit {

/// Shows @p image (stretched for display) with the pattern centre and lets the
/// user click pairs: left click the light point, then the dark point of a
/// similar object; right click or 'u' removes the last point; Enter, Space,
/// 'q', Esc or closing the window ends. Starts from @p start (the pairs of an
/// existing file). Returns the complete pairs. Throws avatar::InvalidState when
/// no window can be opened (no display).
std::vector<PointPair> pickPairs(const tools::WorkingImage& image, cv::Point2d centre,
                                 const std::vector<PointPair>& start);

}  // namespace avatar::lightfit
