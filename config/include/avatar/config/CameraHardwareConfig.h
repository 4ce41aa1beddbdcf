#pragma once
/// @file CameraHardwareConfig.h
/// Image properties, camera identities and the camera feature set (thesis 4.2.4).

#include <avatar/common/ImageFormat.h>

#include <string>

namespace avatar {

/// One adjustable camera feature: a value in the camera's own units, or let
/// the camera adjust it itself.
struct CameraFeature {
    double value{0.0};
    bool automatic{false};
    bool operator==(const CameraFeature& o) const { return value == o.value && automatic == o.automatic; }
};

/// White balance has two components (blue/U and red/V) and one auto flag.
struct WhiteBalance {
    double blueU{0.0};
    double redV{0.0};
    bool automatic{false};
    bool operator==(const WhiteBalance& o) const {
        return blueU == o.blueU && redV == o.redV && automatic == o.automatic;
    }
};

/// The feature set applied to both cameras (IIDC names; thesis 4.5.1).
struct CameraFeatureSet {
    CameraFeature exposure;
    CameraFeature shutter;
    CameraFeature gain;
    WhiteBalance whiteBalance;
    CameraFeature brightness;
    CameraFeature gamma;
    bool operator==(const CameraFeatureSet& o) const {
        return exposure == o.exposure && shutter == o.shutter && gain == o.gain &&
               whiteBalance == o.whiteBalance && brightness == o.brightness && gamma == o.gamma;
    }
};

/// What the cameras deliver and which physical cameras are left and right.
struct CameraHardwareConfig {
    int width{1280};        ///< pixels, 1..16384
    int height{960};        ///< pixels, 1..16384
    int bitDepth{16};       ///< significant bits per sample, 1..16
    int channels{1};        ///< 1 (mono or Bayer) or 3 (colour)
    bool bayer{true};       ///< the single channel is a Bayer mosaic
    BayerPattern bayerPattern{BayerPattern::BG};
    bool endianSwap{false}; ///< swap the bytes of 16-bit samples after acquisition
    std::string leftCameraId;   ///< hardware id (e.g. IIDC GUID "0x00b09d01004a2c1f")
    std::string rightCameraId;
    CameraFeatureSet features;

    bool operator==(const CameraHardwareConfig& o) const {
        return width == o.width && height == o.height && bitDepth == o.bitDepth &&
               channels == o.channels && bayer == o.bayer && bayerPattern == o.bayerPattern &&
               endianSwap == o.endianSwap && leftCameraId == o.leftCameraId &&
               rightCameraId == o.rightCameraId && features == o.features;
    }
};

}  // namespace avatar
