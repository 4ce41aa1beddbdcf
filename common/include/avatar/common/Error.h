#pragma once
/// @file Error.h
/// The project's error hierarchy.
///
/// Error policy: the AVATAR libraries (common, config, acquire, analyze) report
/// failures by throwing an exception derived from avatar::Error. Every message
/// names what caused it: the file, the field or element path, and the value.
/// "No result" that is a normal outcome (no target found, no frame yet) is an
/// std::optional or an empty container, never an exception.

#include <stdexcept>
#include <string>

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

}  // namespace avatar
