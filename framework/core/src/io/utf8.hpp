#pragma once
// UTF-8 validation shared by the text helpers (io/text.cpp) and the configuration reader (config/config.cpp).
#include <cstddef>
#include <string_view>

namespace varbo::detail {

/// Length of the well-formed UTF-8 sequence starting at s[i] (RFC 3629: no overlongs, no surrogates, nothing
/// above U+10FFFF), or 0 when the bytes there are not one.
std::size_t utf8_length(std::string_view s, std::size_t i);

}  // namespace varbo::detail
