#pragma once
/// @file ToolDisplay.h
/// Whether a tool can open a HighGUI window. HighGUI's Qt backend aborts the
/// process when it cannot connect to the X display, so a tool asks first and,
/// when the answer is no, says in its own words what to do instead.

#include <optional>
#include <string>

namespace avatar::tools {

/// When @p display (the value of $DISPLAY) names a local X display (":N" or
/// ":N.S") whose server accepts no connection at its socket: that socket,
/// "/tmp/.X11-unix/XN". Nothing when the server answers, for an empty value or
/// any other form (a remote or forwarded display, which only Qt can try), or
/// when no socket can be made to ask.
std::optional<std::string> unreachableLocalDisplay(const std::string& display);

}  // namespace avatar::tools
