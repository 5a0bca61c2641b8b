#pragma once
// Numeric CSV tables with a header row (data for `varbo fit`, points to predict at).
#include <string>
#include <vector>
#include "varbo/types.hpp"

namespace varbo {

struct CsvTable {
  std::vector<std::string> columns;
  Mat values;  ///< rows × columns
  Index column(const std::string& name) const;  ///< -1 when absent
};

/// Reads a CSV file of numbers with one header line. Errors name the file, line and column.
CsvTable read_csv(const std::string& filename);

/// A double printed so that it reads back exactly.
std::string exact(double v);

}  // namespace varbo
