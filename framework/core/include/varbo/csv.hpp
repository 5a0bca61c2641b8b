#pragma once
// Numeric CSV tables with a header row (data for `varbo fit`, points to predict at).
#include <functional>
#include <string>
#include <vector>
#include "varbo/types.hpp"

namespace varbo {

struct CsvTable {
  std::vector<std::string> columns;
  Mat values;  ///< rows × columns
  std::vector<int> lines;  ///< the file's line number (1-based) of each row, for messages
  Index column(const std::string& name) const;  ///< -1 when absent
};

/// Reads a CSV file of numbers with one header line (cells split by split_csv_line, surrounding spaces dropped). Errors name the file, line and column: a cell that is not
/// a decimal number (parse_decimal; nan and inf are read, for the caller to judge), a row of the wrong width, a
/// column name given twice or empty. Lines may end in \n, \r\n or a lone \r (old Mac files). When `used` is given,
/// only the columns it accepts are read as numbers; the others (notes, dates, a trials table's text) are NaN.
CsvTable read_csv(const std::string& filename, const std::function<bool(const std::string&)>& used = {});

/// One CSV line split into cells with RFC 4180 quoting ("a,""b""" is one cell a,"b"); a trailing \r is dropped.
/// For run-folder tables such as trials.csv, whose `error` column may hold commas and quotes.
std::vector<std::string> split_csv_line(const std::string& line);

/// Every line of a CSV file split by split_csv_line, as text (header included). Empty when the file cannot be
/// read. For run-folder tables such as trials.csv that mix text and numbers.
std::vector<std::vector<std::string>> read_csv_cells(const std::string& filename);

/// A CSV cell of free text (a name, an error message): printable() — valid UTF-8 on one line, control
/// characters and bytes that are not UTF-8 escaped — and quoted (RFC 4180) when it holds a comma or a quote.
std::string csv_text(const std::string& text);

/// A double printed so that it reads back exactly.
std::string exact(double v);

/// A fixed column of trials.csv or of `varbo export` (index, id, state, phase, cost, ok, error, worker, the times and
/// regrets): a cost component of that name would make a second column of it, read by csv tools as the first.
bool is_trials_table_column(const std::string& name);
/// The refusal of such a name for a `what` ("parameter", "component"), one wording wherever it is checked.
std::string trials_column_clash(const std::string& name, const std::string& what);

}  // namespace varbo
