#pragma once
/// @file AcquireSIPFileLoader.h
/// The file backend (thesis 4.2.2): 8-bit stereo pairs from ordinary image
/// files (JPEG, PNG, BMP...), read with StereoImagePairFileIO::readDisplay as
/// BGR. The legacy way to re-run old 8-bit test sets; recorded 16-bit sessions
/// are replayed by RawDataAcquire instead.
///
/// The pairs come from an explicit list of left/right paths or from a pair of
/// printf-style patterns with one integer conversion (`left_%04d.jpg`,
/// `right_%04d.jpg`) counted up from a start index.
///
/// Numbering is the base class's (first pair group 1 member 0). Each pair
/// carries empty camera ids and the time it was read as both timestamps (the
/// files hold no capture time).
///
/// Errors: a missing or undecodable file, or two files of different size, is an
/// AcquisitionError naming the file(s); status() is then Recovering and the
/// next acquire() goes on with the next pair. As soon as the last pair has been
/// acquired (or failed) status() is Finished, and acquire() throws an
/// AcquisitionError saying so. Not thread-safe except status() and the counters.

#include <avatar/acquire/AcquireStereoImagePair.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace avatar {

/// The two files of one pair.
struct StereoFilePaths {
    std::filesystem::path left;
    std::filesystem::path right;
};

/// Pairs named by two printf-style patterns with exactly one integer
/// conversion each: `%d`, `%u`, or with a field width and zero padding
/// (`%4d`, `%04d`); `%%` is a literal percent sign. No other conversion is
/// allowed.
struct StereoFilePattern {
    std::string left;          ///< e.g. "/data/test7/left_%04d.jpg"
    std::string right;         ///< e.g. "/data/test7/right_%04d.jpg"
    std::uint64_t start{0};    ///< index of the first pair
    /// Number of pairs. Unset: the sequence ends at the first index for which
    /// neither file exists (a missing left or right file alone is an error).
    /// Set: every index start .. start+count-1 must have both files.
    std::optional<std::uint64_t> count;

    /// Throws avatar::InvalidArgument naming the pattern and what is wrong.
    void validate() const;
    /// The two paths of pair @p index (validate() first).
    StereoFilePaths at(std::uint64_t index) const;
};

class AcquireSIPFileLoader final : public AcquireStereoImagePair {
public:
    /// Delivers @p pairs in order. An empty list is Finished from the start.
    explicit AcquireSIPFileLoader(std::vector<StereoFilePaths> pairs, std::uint32_t groupSize = 99999);
    /// Delivers the pairs named by @p pattern. Throws avatar::InvalidArgument
    /// when the pattern is invalid (StereoFilePattern::validate()).
    explicit AcquireSIPFileLoader(StereoFilePattern pattern, std::uint32_t groupSize = 99999);

    std::string name() const override { return "files"; }
    /// Ok, Recovering after a pair that could not be read (message names the
    /// file), Finished after the last pair. Thread-safe.
    AcquisitionStatus status() const override;

    /// Pairs delivered and pairs that could not be read so far.
    std::size_t deliveredCount() const;
    std::size_t failedCount() const;

protected:
    AcquiredPair grab() override;

private:
    /// The paths of the next pair, or nothing at the end of the list or pattern.
    std::optional<StereoFilePaths> peek() const;
    void finish();

    std::vector<StereoFilePaths> list_;
    std::optional<StereoFilePattern> pattern_;
    std::uint64_t position_{0};  ///< index into list_, or the next pattern index

    mutable std::mutex mutex_;
    AcquisitionStatus status_;
    std::size_t delivered_{0};
    std::size_t failed_{0};
    std::string lastError_;
};

}  // namespace avatar
