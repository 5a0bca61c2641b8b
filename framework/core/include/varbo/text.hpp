#pragma once
// Free text that came from outside (a command's output, an error message) made safe to keep: bounded in
// size and valid UTF-8 on one line, so trials.csv, log.txt, the study store and the terminal stay readable.
#include <cstddef>
#include <string>
#include <string_view>

namespace varbo {

/// ASCII character classes, whatever the process's locale. std::isalnum follows LC_CTYPE: in a Latin-1 locale (a
/// host's setlocale(LC_ALL, "de_DE")) each byte of a UTF-8 'µ' is a letter, so a name the CLI refuses was accepted
/// from Python and the study then opened nowhere else (red team, session 31).
constexpr bool ascii_digit(char c) { return c >= '0' && c <= '9'; }
constexpr bool ascii_alpha(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); }
constexpr bool ascii_alnum(char c) { return ascii_alpha(c) || ascii_digit(c); }
constexpr bool ascii_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v'; }

/// `text` if it is at most 2·keep bytes (plus a little); else its first and last `keep` bytes around a
/// "[... N bytes omitted ...]" marker (cut at UTF-8 character boundaries).
std::string abbreviate(std::string_view text, std::size_t keep = 1024);

/// Valid UTF-8 on one line: well-formed UTF-8 sequences are kept, \n \r \t become those two-character
/// escapes, other control bytes and bytes that are not UTF-8 become \xHH.
std::string printable(std::string_view text);
/// What a terminal shows as text and never obeys: printable(), but line breaks and tabs kept, and the C1 controls
/// (U+0080–U+009F, e.g. U+009B, a one-character CSI) escaped too, as \uXXXX, with the characters a terminal shows
/// as nothing or a blank or that reorder the text (no-break spaces, zero-width characters, directional overrides,
/// the byte order mark). For messages varbo prints to a terminal: a
/// parameter name of a study from elsewhere held ESC sequences that retitled and cleared the user's terminal.
std::string terminal_text(std::string_view text);
/// The text with the password of every PostgreSQL URL in it shown as *** (`postgresql://user:***@host/db`, and a
/// `password=` / `sslpassword=` parameter): applied to every log line (terminal and log.txt) and error message, so
/// that no path through the study code can write a password into a run folder (audit, session 47).
std::string hide_url_passwords(std::string_view text);
/// terminal_text(printable(text)): one line a terminal shows and never obeys, for a name or label printed inside a
/// line of output (`varbo suggest`'s name=label, `varbo select`'s θ): a label holding ESC cleared the screen, one
/// holding a newline split the line a script reads (red team, session 31).
std::string terminal_line(std::string_view text);
/// `text` as one word of a POSIX shell command: unchanged when it holds only characters no shell treats
/// specially (letters, digits, and _ - . / : , + = @ %), else in single quotes. For the commands varbo prints
/// for a user to paste: a PostgreSQL URL holds '&', which split `varbo observe URL 2 0.5` into two commands.
std::string shell_word(std::string_view text);

/// Offset of the first byte of `s` that does not start a well-formed UTF-8 sequence (RFC 3629), or npos.
std::size_t invalid_utf8_at(std::string_view s);

/// printable(abbreviate(text, keep)): what to keep of a message of unknown size and content.
inline std::string safe_text(std::string_view text, std::size_t keep = 1024) {
  return printable(abbreviate(text, keep));
}

}  // namespace varbo
