#include "args_placement.hpp"

#include <cctype>

namespace varbo::tasks {

namespace {

bool blank(char c) { return c == ' ' || c == '\t'; }

/// The index just past the `)` closing the `$(` whose `(` is at `open` (nesting and quotes followed), or npos.
std::size_t skip_substitution(const std::string& s, std::size_t open) {
  int depth = 0;
  char quote = 0;
  for (std::size_t i = open; i < s.size(); ++i) {
    const char c = s[i];
    if (quote) {
      if (c == '\\' && quote == '"') ++i;
      else if (c == quote) quote = 0;
      continue;
    }
    if (c == '\\') ++i;
    else if (c == '\'' || c == '"') quote = c;
    else if (c == '(') ++depth;
    else if (c == ')' && --depth == 0) return i + 1;
  }
  return std::string::npos;
}

/// Whether `s` at `i` (just past a `$`) names a positional parameter: @, *, 1–9, or {@ {* {1 … (also ${1:-x}).
bool positional_after_dollar(const std::string& s, std::size_t i) {
  if (i >= s.size()) return false;
  char c = s[i];
  if (c == '{' && i + 1 < s.size()) c = s[i + 1];
  return c == '@' || c == '*' || (c >= '1' && c <= '9');
}

}  // namespace

ArgsPlacement args_placement(const std::string& command, std::string* what) {
  // Trailing blanks and line breaks (a YAML block scalar ends with one) are not part of the command.
  std::size_t end = command.size();
  while (end > 0 && std::isspace(static_cast<unsigned char>(command[end - 1]))) --end;
  const std::string s = command.substr(0, end);
  bool positional = false;
  std::string refused;
  char quote = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {  // on to the end: a $1 after a pipe counts
    const char c = s[i];
    if (quote == '\'') {
      if (c == '\'') quote = 0;
      continue;
    }
    if (c == '\\') {
      ++i;
      continue;
    }
    if (c == '$') {
      if (positional_after_dollar(s, i + 1)) positional = true;
      if (i + 1 < s.size() && s[i + 1] == '(') {  // $( … ): one word, whatever it holds
        const std::size_t close = skip_substitution(s, i + 1);
        if (close == std::string::npos) break;
        i = close - 1;
      }
      continue;
    }
    if (quote == '"') {
      if (c == '"') quote = 0;
      continue;
    }
    if (c == '\'' || c == '"') {
      quote = c;
      continue;
    }
    if (c == '`') {  // `…`: one word
      const std::size_t close = s.find('`', i + 1);
      if (close == std::string::npos) break;
      i = close;
      continue;
    }
    const bool word_start = i == 0 || blank(s[i - 1]);
    if (c == '#' && word_start) {  // the rest is a comment: a $1 there names nothing
      if (refused.empty()) refused = "a comment '#'";
      break;
    }
    if (!refused.empty()) continue;  // the first one is named
    if (c == '|') refused = "a pipe '|'";
    else if (c == ';') refused = "a list ';'";
    else if (c == '&' && !(i > 0 && (s[i - 1] == '>' || s[i - 1] == '<')))  // not a redirection's 2>&1
      refused = "'&' (a list or a background command)";
    else if (c == '\n') refused = "a line break (two commands)";
    else if (c == '(' || c == ')') refused = "a subshell '( … )'";
  }
  // A command that names its positional parameters says itself where θ goes, pipes and all.
  if (positional) return ArgsPlacement::Positional;
  if (!refused.empty()) {
    if (what) *what = refused;
    return ArgsPlacement::Refused;
  }
  return ArgsPlacement::Append;
}

}  // namespace varbo::tasks
