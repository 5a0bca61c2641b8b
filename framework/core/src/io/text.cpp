#include "varbo/text.hpp"

#include <cstdint>
#include <cstring>

#include <cctype>

#include <algorithm>
#include <regex>

#include "utf8.hpp"

#include <fmt/format.h>

namespace varbo {

namespace {

bool is_continuation(unsigned char c) { return (c & 0xC0) == 0x80; }

}  // namespace

namespace detail {

std::size_t utf8_length(std::string_view s, std::size_t i) {
  const auto b = [&](std::size_t k) { return static_cast<unsigned char>(s[i + k]); };
  const unsigned char c = b(0);
  std::size_t n = 0;
  unsigned char lo = 0x80, hi = 0xBF;  // allowed range of the second byte
  if (c < 0x80) return 1;
  if (c >= 0xC2 && c <= 0xDF) n = 2;
  else if (c == 0xE0) n = 3, lo = 0xA0;
  else if (c == 0xED) n = 3, hi = 0x9F;
  else if (c >= 0xE1 && c <= 0xEF) n = 3;
  else if (c == 0xF0) n = 4, lo = 0x90;
  else if (c == 0xF4) n = 4, hi = 0x8F;
  else if (c >= 0xF1 && c <= 0xF3) n = 4;
  else return 0;
  if (i + n > s.size()) return 0;
  if (b(1) < lo || b(1) > hi) return 0;
  for (std::size_t k = 2; k < n; ++k)
    if (!is_continuation(b(k))) return 0;
  return n;
}

}  // namespace detail

std::string abbreviate(std::string_view text, std::size_t keep) {
  if (text.size() <= 2 * keep + 64) return std::string(text);
  std::size_t head = keep, tail = text.size() - keep;
  // Do not split a character: move the cuts off continuation bytes (at most 3 steps for UTF-8).
  for (int k = 0; k < 3 && head > 0 && is_continuation(static_cast<unsigned char>(text[head])); ++k) --head;
  for (int k = 0; k < 3 && tail < text.size() && is_continuation(static_cast<unsigned char>(text[tail])); ++k) ++tail;
  return fmt::format("{}[... {} bytes omitted ...]{}", text.substr(0, head), tail - head, text.substr(tail));
}

std::string shell_word(std::string_view text) {
  const bool plain = !text.empty() && std::all_of(text.begin(), text.end(), [](char ch) {
    return ascii_alnum(ch) || (ch != '\0' && std::strchr("_-./:,+=@%", ch) != nullptr);
  });
  if (plain) return std::string(text);
  std::string out = "'";
  for (const char ch : text) out += ch == '\'' ? std::string("'\\''") : std::string(1, ch);
  return out + "'";
}

std::string printable(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size();) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    const std::size_t n = detail::utf8_length(text, i);
    if (n == 1 && c >= 0x20 && c != 0x7F) {
      out += static_cast<char>(c);
    } else if (n > 1) {
      out.append(text.substr(i, n));
    } else if (c == '\n') {
      out += "\\n";
    } else if (c == '\r') {
      out += "\\r";
    } else if (c == '\t') {
      out += "\\t";
    } else {
      out += fmt::format("\\x{:02X}", c);
    }
    i += n > 0 ? n : 1;
  }
  return out;
}

namespace {

/// Code points a terminal shows as nothing, as a blank or by reordering the text around them: C1 controls (U+0080–
/// U+009F; U+009B is a one-character CSI), no-break and other spaces, the soft hyphen, zero-width characters,
/// directional marks and overrides (the "Trojan Source" characters), the byte order mark. A name holding one looks
/// like another name (a parameter "x1" with a zero-width space printed as "x1" in "unknown parameter 'x1'"; audit,
/// session 44), so varbo's messages show them as \uXXXX.
bool invisible(char32_t c) {
  return (c >= 0x80 && c <= 0x9F) || c == 0xA0 || c == 0xAD || c == 0x34F || c == 0x61C || c == 0x115F ||
         c == 0x1160 || c == 0x17B4 || c == 0x17B5 || c == 0x180E || (c >= 0x2000 && c <= 0x200F) ||
         (c >= 0x2028 && c <= 0x202F) || (c >= 0x205F && c <= 0x206F) || c == 0x3000 || c == 0x3164 ||
         c == 0xFEFF || c == 0xFFA0 || (c >= 0xFFF9 && c <= 0xFFFB);
}

/// The code point of the well-formed UTF-8 sequence of `n` bytes at s[i].
char32_t code_point(std::string_view s, std::size_t i, std::size_t n) {
  const auto b = [&](std::size_t k) { return static_cast<char32_t>(static_cast<unsigned char>(s[i + k])); };
  if (n == 2) return ((b(0) & 0x1F) << 6) | (b(1) & 0x3F);
  if (n == 3) return ((b(0) & 0x0F) << 12) | ((b(1) & 0x3F) << 6) | (b(2) & 0x3F);
  return ((b(0) & 0x07) << 18) | ((b(1) & 0x3F) << 12) | ((b(2) & 0x3F) << 6) | (b(3) & 0x3F);
}

}  // namespace

std::string hide_url_passwords(std::string_view text) {
  if (text.find("postgres") == std::string_view::npos && text.find("password=") == std::string_view::npos)
    return std::string(text);
  static const std::regex user_password(R"((postgres(?:ql)?://[^:/@\s'"?&]*):[^@/\s'"]*@)");
  static const std::regex password_parameter(R"(((?:^|[?&\s'"])[A-Za-z_]*password=)[^&\s'"]*)");
  std::string out = std::regex_replace(std::string(text), user_password, "$1:***@");
  return std::regex_replace(out, password_parameter, "$1***");
}

std::string terminal_text(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  std::size_t start = 0;
  for (std::size_t i = 0; i <= text.size(); ++i) {
    if (i < text.size() && text[i] != '\n' && text[i] != '\t') continue;
    const std::string part = printable(text.substr(start, i - start));
    for (std::size_t j = 0; j < part.size();) {
      const std::size_t n = std::max<std::size_t>(detail::utf8_length(part, j), 1);  // printable() output is UTF-8
      if (n > 1 && invisible(code_point(part, j, n)))
        out += fmt::format("\\u{:04X}", static_cast<std::uint32_t>(code_point(part, j, n)));
      else
        out.append(part, j, n);
      j += n;
    }
    if (i < text.size()) out += text[i];
    start = i + 1;
  }
  return out;
}

std::string terminal_line(std::string_view text) { return terminal_text(printable(text)); }

std::size_t invalid_utf8_at(std::string_view s) {
  for (std::size_t i = 0; i < s.size();) {
    const std::size_t n = detail::utf8_length(s, i);
    if (n == 0) return i;
    i += n;
  }
  return std::string::npos;
}

}  // namespace varbo
