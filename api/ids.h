// Job ids are the only user-controlled value that ever becomes part of a file-system path
// (DIR/jobs/<id>/). They are random (not guessable, not sequential, so one client cannot
// enumerate another's jobs) and every id that arrives from outside is checked against one
// strict pattern before it touches the store or the disk, so "..", "/" or "%2f" can never
// reach a path.
#pragma once

#include <string>
#include <string_view>

namespace glam::api {

// 16 lower-case hex characters (64 random bits from std::random_device).
std::string NewJobId();

// True only for exactly 16 characters in [0-9a-f].
bool IsValidJobId(std::string_view id);

// Parses a non-negative decimal integer (no sign, no spaces, at most 18 digits) as used for
// tile/submap numbers and paging parameters in URLs. Returns false for anything else.
bool ParseNonNegativeInt(std::string_view text, long long* value);

}  // namespace glam::api
