#include "varbo/csv.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstdlib>
#include <algorithm>
#include <fstream>
#include <limits>

#include "varbo/errors.hpp"
#include "varbo/regular_file.hpp"
#include "varbo/numbers.hpp"
#include "varbo/text.hpp"

namespace varbo {

Index CsvTable::column(const std::string& name) const {
  for (std::size_t i = 0; i < columns.size(); ++i)
    if (columns[i] == name) return static_cast<Index>(i);
  return -1;
}

std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> cells(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        cells.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        cells.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      cells.emplace_back();
    } else if (c != '\r') {
      cells.back() += c;
    }
  }
  return cells;
}

namespace {

/// A file written with another separator (a spreadsheet in a locale with decimal commas writes ';', a "CSV" export
/// may be tab-separated) reads as one column per line; name the separator instead of a missing column.
std::string separator_hint(const std::string& line) {
  if (line.find(';') != std::string::npos)
    return "; the line looks semicolon-separated (';'): varbo reads comma-separated values with a decimal point, "
           "e.g. x1,x2,y";
  if (line.find('\t') != std::string::npos)
    return "; the line looks tab-separated: varbo reads comma-separated values with a decimal point, e.g. x1,x2,y";
  return "";
}

}  // namespace

namespace {
/// One line ending in \n, \r\n or a lone \r: a file saved with old Mac line endings was one line, and its
/// error ("no column named 'y'") said nothing of why.
bool next_line(std::istream& in, std::string& line) {
  line.clear();
  int c;
  bool any = false;
  while ((c = in.get()) != std::char_traits<char>::eof()) {
    any = true;
    if (c == '\n') return true;
    if (c == '\r') {
      if (in.peek() == '\n') in.get();
      return true;
    }
    line += static_cast<char>(c);
  }
  return any;
}
}  // namespace

CsvTable read_csv(const std::string& filename, const std::function<bool(const std::string&)>& used) {
  // Only a regular file: a FIFO would block forever, /dev/zero would fill memory with one endless line.
  require_regular_file(filename, "a CSV file");
  std::ifstream in(filename);
  if (!in) throw InputError(fmt::format("{}: cannot open CSV file", filename));
  CsvTable t;
  std::string line;
  int lineno = 0;
  std::vector<std::vector<double>> rows;
  std::vector<bool> numeric;
  std::string first_comment;  // a header NumPy's savetxt wrote as a comment ("# a,b,y")
  int first_comment_line = 0;
  while (next_line(in, line)) {
    ++lineno;
    // UTF-16 (Excel's "Unicode Text", PowerShell's default) was refused as "a NUL byte (binary data?)".
    if (lineno == 1 && (line.rfind("\xFF\xFE", 0) == 0 || line.rfind("\xFE\xFF", 0) == 0))
      throw InputError(fmt::format("{}: UTF-16 text; expected UTF-8 (in a spreadsheet save as \"CSV UTF-8\"; or "
                                   "iconv -f UTF-16 -t UTF-8)",
                                   filename));
    // A UTF-8 byte order mark (spreadsheets write one) is not part of the first column's name.
    if (lineno == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    if (line[0] == '#') {  // a comment line (docs/studies.md)
      if (t.columns.empty() && first_comment_line == 0) {
        first_comment = line;
        first_comment_line = lineno;
      }
      continue;
    }
    // An odd number of quotes: a quoted value holding a line break (RFC 4180; a note typed in a spreadsheet cell
    // with Alt+Enter), continued on the next lines until its quote closes. It was refused as "unterminated quote"
    // on a file Python's csv module and pandas read (audit, session 48). A quote never closed is named at the
    // line where the value began.
    const int first_line = lineno;
    while (std::count(line.begin(), line.end(), '"') % 2 != 0) {
      std::string more;
      if (!next_line(in, more))
        throw InputError(fmt::format("{}:{}: unterminated quote (the value opened here never closes); expected "
                                     "comma-separated values",
                                     filename, first_line));
      ++lineno;
      line += '\n';
      line += more;
    }
    // A data file is text: a NUL byte means binary data.
    if (line.find('\0') != std::string::npos)
      throw InputError(fmt::format("{}:{}: a NUL byte (binary data?); expected comma-separated text", filename, first_line));
    auto cells = split_csv_line(line);
    for (auto& c : cells) {  // spaces around a value are not part of it
      const auto b = c.find_first_not_of(" \t");
      c = b == std::string::npos ? std::string() : c.substr(b, c.find_last_not_of(" \t") - b + 1);
    }
    if (t.columns.empty()) {
      // A file without a header line (MATLAB's writematrix, NumPy's savetxt, whose header is a '#' comment): its
      // first row was taken for the names, and the error said only "no column named 'y'".
      if (std::all_of(cells.begin(), cells.end(), [](const std::string& c) { return parse_decimal(c).has_value(); }))
        throw InputError(fmt::format(
            "{}:{}: the header line is all numbers: a file without column names{}; add a header line such as "
            "x1,x2,y",
            filename, first_line,
            first_comment_line > 0
                ? fmt::format(" (line {} '{}' is a comment: NumPy's savetxt writes its header so; pass comments='')",
                              first_comment_line, safe_text(first_comment, 40))
                : std::string()));
      if (cells.size() == 1 && !separator_hint(line).empty())
        throw InputError(fmt::format("{}:{}: the header is a single column '{}'{}", filename, first_line,
                                     printable(cells[0]), separator_hint(line)));
      // pandas' DataFrame.to_csv writes its index under an empty first name (",x,y"); pandas reads it back as
      // "Unnamed: 0", and so does this reader, so that `varbo fit` treats it as the index it is (audit, session 48:
      // the most common way a Python user writes a CSV was refused).
      if (cells.size() > 1 && cells[0].empty()) cells[0] = "Unnamed: 0";
      for (std::size_t c = 0; c < cells.size(); ++c) {
        if (cells[c].empty())
          throw InputError(fmt::format("{}:{}: column {} of the header has no name", filename, first_line, c + 1));
        for (std::size_t k = 0; k < c; ++k)
          if (cells[k] == cells[c])
            throw InputError(fmt::format("{}:{}: column name '{}' appears twice (columns {} and {}); each column "
                                         "needs its own name",
                                         filename, first_line, cells[c], k + 1, c + 1));
      }
      t.columns = cells;
      for (const auto& name : t.columns) numeric.push_back(!used || used(name));
      continue;
    }
    if (cells.size() != t.columns.size())
      throw InputError(fmt::format("{}:{}: expected {} comma-separated values (as in the header), found {}{}", filename,
                                   first_line, t.columns.size(), cells.size(), separator_hint(line)));
    std::vector<double> row;
    for (std::size_t c = 0; c < cells.size(); ++c) {
      if (!numeric[c]) {
        row.push_back(std::numeric_limits<double>::quiet_NaN());
        continue;
      }
      const std::optional<double> v = parse_decimal(cells[c]);
      if (!v)
        throw InputError(fmt::format("{}:{}: column '{}': expected a decimal number, got '{}'", filename, first_line,
                                     safe_text(t.columns[c], 40), safe_text(cells[c], 40)));
      row.push_back(*v);
    }
    rows.push_back(std::move(row));
    t.lines.push_back(first_line);
  }
  if (t.columns.empty()) throw InputError(fmt::format("{}: empty file (expected a header line)", filename));
  t.values.resize(static_cast<Index>(rows.size()), static_cast<Index>(t.columns.size()));
  for (std::size_t r = 0; r < rows.size(); ++r)
    for (std::size_t c = 0; c < t.columns.size(); ++c) t.values(r, c) = rows[r][c];
  return t;
}

std::vector<std::vector<std::string>> read_csv_cells(const std::string& filename) {
  require_regular_file(filename, "a CSV file");
  std::ifstream in(filename);
  std::vector<std::vector<std::string>> rows;
  std::string line;
  while (std::getline(in, line)) rows.push_back(split_csv_line(line));
  return rows;
}

std::string csv_text(const std::string& text) {
  const std::string s = printable(text);
  if (s.find_first_of(",\"") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string exact(double v) { return fmt::format("{}", v); }  // fmt prints the shortest round-trip form

bool is_trials_table_column(const std::string& name) {
  static const std::vector<std::string> fixed = {
      "index", "id", "state", "phase", "cost", "ok", "error", "worker", "created_at", "finished_at", "finish_seq",
      "fit_seconds", "acquisition_seconds", "evaluation_seconds", "regret_best_observed", "regret_recommended"};
  return std::find(fixed.begin(), fixed.end(), name) != fixed.end();
}

std::string trials_column_clash(const std::string& name, const std::string& what) {
  return fmt::format("'{}' names a column of the trials table (index, phase, cost, ok, error, the timings); name the "
                     "{} otherwise",
                     name, what);
}

}  // namespace varbo
