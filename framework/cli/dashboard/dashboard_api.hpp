#pragma once
// The dashboard's JSON API (docs/dashboard.md): one function per resource, from a path and its query to a status
// and a JSON body, with no HTTP in sight (dashboard_server.cpp does that), so each answer is testable alone.
// Errors are {"error": "..."} with a 4xx status: 400 for a malformed request (a κ that is not a finite number, an
// unknown parameter), 404 for an unknown resource or a study that has gone, 409 when no model can be had yet.
#include <map>
#include <mutex>
#include <string>

#include "dashboard_study.hpp"

namespace varbo::cli {

struct ApiResponse {
  int status = 200;
  std::string body;  ///< JSON
};

/// Query parameters (name → value, as HTTP gives them; a repeated name keeps its first value).
using ApiQuery = std::multimap<std::string, std::string>;

class DashboardApi {
 public:
  explicit DashboardApi(DashboardStudy& study) : study_(study) {}
  /// GET `path` (e.g. "/api/trials") with `query`. Never throws: every failure is an error response.
  ApiResponse get(const std::string& path, const ApiQuery& query);

 private:
  std::string summary();
  std::string trials(const ApiQuery& query);
  std::string history();
  std::string model();
  std::string select(const ApiQuery& query);
  std::string slices(const ApiQuery& query);
  std::string grid(const ApiQuery& query);
  std::string region();
  std::string rescore(const ApiQuery& query);
  DashboardStudy& study_;
  std::mutex rescore_mutex_;
  std::map<std::string, std::string> rescore_cache_;  ///< request key → answer (a re-weighting refits a critic)
};

/// JSON text of `j`: control characters escaped, invalid UTF-8 replaced (a hostile name must not break a reply).
std::string json_text(const nlohmann::json& j);

}  // namespace varbo::cli
