#pragma once
/// @file Error.h
/// The project's error hierarchy.
///
/// Error policy: the AVATAR libraries report failures by throwing an exception
/// derived from avatar::Error, of the type that says what kind of failure it
/// is, so that a caller (the TAU protocol's error codes, a tool's exit status)
/// can act on the type alone, never on the text. Every message names what
/// caused it: the file, the field or element path, and the value. "No result"
/// that is a normal outcome (no target found, no frame yet) is an
/// std::optional or an empty container, never an exception.
///
/// The types, and who throws them:
/// - IoError: a file or device could not be opened, read or written.
/// - FormatError: data does not have the expected layout.
/// - InvalidArgument: a caller passed a value the function cannot accept;
///   ConfigError (ConfigXml.h) is the one for a rejected configuration.
/// - TimedOut: an operation did not finish within its time limit.
/// - InvalidState: a request that is valid, but not in the current state.
/// - NotAvailable: what was asked for does not exist (yet).
/// - AcquisitionError (AcquireStereoImagePair.h): no stereo pair could be had.

#include <stdexcept>
#include <string>
#include <utility>

namespace avatar {

/// Base of every exception the project throws.
class Error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// A file or device could not be opened, read or written. The message names the path.
class IoError : public Error {
public:
    using Error::Error;
};

/// Data did not have the expected layout: a raw file of the wrong size, a file
/// name that does not parse, an image of an unsupported type.
class FormatError : public Error {
public:
    using Error::Error;
};

/// A caller passed a value that the function cannot accept.
class InvalidArgument : public Error {
public:
    using Error::Error;
};

/// An operation did not finish within its time limit (a snapshot, a
/// configuration change). The message names the operation and the limit.
class TimedOut : public Error {
public:
    using Error::Error;
};

/// A request that is valid but cannot be carried out in the current state:
/// searching on a source that has failed or has no more pairs, a request to a
/// component that is shutting down. The message names the state.
class InvalidState : public Error {
public:
    using Error::Error;
};

/// What was asked for does not exist, or not yet: results before the first
/// iteration, images that were never taken.
class NotAvailable : public Error {
public:
    using Error::Error;
};

/// A problem at one place of a structured document (a configuration, a scene
/// file): the four facts every such error carries, written once. what() reads
///   "<source>:<line>: <element path>: <problem>"
/// e.g. "scorpion.xml:42: /avatar/targets/target[2]/redGreen/min: expected a number, got 'abc'".
/// @tparam Base the kind of error it is (InvalidArgument for a configuration).
template <typename Base>
class DocumentError : public Base {
public:
    DocumentError(std::string source, int line, std::string elementPath, std::string problem)
        : Base(source + ":" + std::to_string(line) + ": " + elementPath + ": " + problem),
          source_(std::move(source)),
          line_(line),
          path_(std::move(elementPath)),
          problem_(std::move(problem)) {}

    /// The file path as given to the reader, the name given with a document
    /// held in memory, or "<memory>" for a value checked in code.
    const std::string& source() const { return source_; }
    int line() const { return line_; }                        ///< 1-based, 0 if unknown
    const std::string& elementPath() const { return path_; }  ///< e.g. "/avatar/match/method"
    const std::string& problem() const { return problem_; }

private:
    std::string source_;
    int line_;
    std::string path_;
    std::string problem_;
};

}  // namespace avatar
