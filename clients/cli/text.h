// Text quoted for JSON and for the shell (coopdyn eval, bench, view, log, spy).
#pragma once

#include <string>

namespace coopdyn::cli {

// s as a JSON string literal: quotes, backslashes and control characters escaped, and "</" written
// as "<\/" so that no name can close an inline <script> (coopdyn view).
std::string json_string(const std::string& s);

// s as one shell word: as it is when it holds only characters the shell leaves alone, else in
// single quotes (for std::system and for printing commands a user can paste).
std::string shell_quote(const std::string& s);

}  // namespace coopdyn::cli
