#pragma once
/// @file FeatureSet.h
/// The procedure of avatar-featureset (thesis 4.2.4, 4.5.1) on a running
/// backend, so the tests drive it in-process too: let the cameras adjust the
/// chosen features themselves, poll until every automatic value is stable,
/// take the values, switch the cameras to manual with them and check that the
/// cameras keep them. A feature a camera lacks is reported, never an error.
/// User guide: docs/tools/avatar-featureset.md

#include <avatar/acquire/AcquireStereoImagePair.h>
#include <avatar/acquire/CameraReport.h>
#include <avatar/config/AvatarConfig.h>

#include <array>
#include <chrono>
#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace avatar::featureset {

struct Options {
    /// The features to let the cameras adjust (cameraFeatureNames()).
    std::vector<std::string> features{"exposure", "gain", "whiteBalance"};
    /// A value is stable when it changes by at most this fraction from one read to the next.
    double tolerance{0.01};
    /// Consecutive stable reads that make a value settled.
    int stableReads{5};
    /// Pause between reads.
    std::chrono::milliseconds poll{200};
    /// Longest wait for every automatic value to settle.
    std::chrono::duration<double> timeout{30.0};
    /// Called after every read with the fewest stable reads of any automatic value so far and the reads made.
    std::function<void(int leastStable, int reads)> progress;

    /// Throws avatar::InvalidArgument naming the bad field as avatar-featureset's
    /// option spells it ("tolerance", "stable-reads", "poll-ms", "settle-timeout").
    void validate() const;
};

/// What happened to one feature on one camera.
enum class Mode {
    Missing,    ///< the camera does not have it
    Fixed,      ///< it has it but does not adjust it itself: its current value is kept
    Automatic,  ///< it adjusted it itself
};
/// "missing", "no automatic mode", "automatic".
const char* toString(Mode mode);

/// One feature, both cameras.
struct FeatureResult {
    std::string name;
    std::array<Mode, 2> mode{Mode::Missing, Mode::Missing};  ///< left, right
    std::array<FeatureReading, 2> reading;                   ///< the last reading before switching to manual
    /// Since the start of settling, when the last automatic camera's value
    /// became stable (its stableReads-th stable read); unset when no camera adjusts it.
    std::optional<double> settledAfterS;
    bool stored{false};  ///< some camera has it: its value is in Result::config
    double value{0.0};   ///< what is stored (white balance: blue/U)
    double redV{0.0};    ///< white balance: red/V
    /// After switching to manual: whether each camera that has the feature reports the stored value.
    std::array<std::optional<bool>, 2> verified;
    std::array<std::string, 2> verifyNote;  ///< what the camera reports instead, when not verified
};

struct Result {
    std::array<std::string, 2> cameraIds;  ///< left, right, as the cameras report them
    std::vector<FeatureResult> features;   ///< in the order asked, each once
    std::vector<std::string> notApplicable;  ///< features skipped with the reason ("whiteBalance: ...")
    bool settleNeeded{false};  ///< some camera adjusts some feature itself
    double settledS{0.0};      ///< how long settling took
    int reads{0};              ///< feature reads made up to the settled values (not the check after)
    std::size_t pairs{0};      ///< pairs grabbed while settling
    std::vector<std::string> pairFailures;
    /// The configuration to store: the original with each stored feature manual at its value.
    AvatarConfig config;
    /// Cameras that did not keep a stored value ("gain on the left camera X reports ..."); empty when all did.
    std::vector<std::string> mismatches;
};

/// The stored value of several cameras' readings: their mean, rounded when
/// every reading is an integer (as IIDC values are).
double storedValue(const std::vector<double>& readings);

/// Runs the procedure on @p acquisition, which holds @p original applied.
/// Leaves the cameras in manual mode with the stored values. Throws
/// avatar::TimedOut when the automatic values do not settle within the
/// timeout (naming the feature, the camera and the last change; @p original
/// is applied again first), and what the backend throws (AcquisitionError
/// naming the camera, NotAvailable for a backend without cameras).
Result run(AcquireStereoImagePair& acquisition, const AvatarConfig& original, const Options& options);

}  // namespace avatar::featureset
