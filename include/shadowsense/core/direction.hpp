// The four movement directions in the robot's frame (paper 5.2.3), shared by the touch state
// machine, the scene generator's slides and the dataset format.
#pragma once

#include <shadowsense/core/error.hpp>

#include <array>
#include <string>
#include <string_view>

SHADOWSENSE_NAMESPACE_BEGIN

// `none` means "no movement / not decided"; it is never a slide's label.
enum class Direction { none, left, right, front, back };

// The four movement directions, without none.
inline constexpr std::array<Direction, 4> all_directions{Direction::left, Direction::right,
                                                         Direction::front, Direction::back};

inline const char* to_string(Direction d) {
  switch (d) {
  case Direction::none:
    return "none";
  case Direction::left:
    return "left";
  case Direction::right:
    return "right";
  case Direction::front:
    return "front";
  case Direction::back:
    return "back";
  }
  return "?";
}

// Parses "left", "right", "front", "back" (and "none"); throws InvalidArgument otherwise.
inline Direction direction_from_string(std::string_view s) {
  if (s == "none") return Direction::none;
  for (Direction d : all_directions)
    if (s == to_string(d)) return d;
  SHADOWSENSE_THROW(InvalidArgument("direction '" + std::string(s) +
                                    "' is unknown; expected left, right, front, back or none"));
}

// Parses one of the four movement directions; "none" is rejected (a slide always moves).
inline Direction movement_direction_from_string(std::string_view s) {
  for (Direction d : all_directions)
    if (s == to_string(d)) return d;
  SHADOWSENSE_THROW(InvalidArgument("unknown direction '" + std::string(s) +
                                    "'; expected left, right, front or back"));
}

SHADOWSENSE_NAMESPACE_END
