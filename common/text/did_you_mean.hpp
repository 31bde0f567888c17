// "Did you mean ...": the closest known name to a misspelt one, for the scene reader's keys,
// sections and choices (protocol/config/scene_reader.hpp), the solid's model names and the
// executables' flags (common/text/cli_parse.hpp). One implementation for all of them.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace cosim::protocol {

/// Levenshtein distance.
std::size_t edit_distance(std::string_view a, std::string_view b);

/// The known name `got` most likely meant, or empty: the closest within 2 edits (3 for names
/// of 8 or more characters); else the shortest name that begins with `got` (2 or more
/// characters): a unit suffix or an ending left off (theta -> theta_deg, corotation ->
/// corotational, --step -> --steps).
std::string_view closest_name(std::string_view got, const std::vector<std::string_view>& allowed);

/// " (did you mean \"NAME\"?)" for closest_name(), or "".
std::string did_you_mean(std::string_view got, const std::vector<std::string_view>& allowed);

}  // namespace cosim::protocol
