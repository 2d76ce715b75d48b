/// \file gdal_session.h
/// \brief What every GDAL call of the adapter runs inside: the drivers registered once, GDAL's error
/// messages captured (not printed) so they can be put into the adapter's exceptions, and no PAM side
/// files (".aux.xml") written beside our outputs. All of it on the calling thread only.
#pragma once

#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal.h>

#include <mutex>
#include <string>

namespace dw {
namespace gdal {
namespace detail {

class GdalSession {
 public:
  GdalSession() {
    static std::once_flag once;
    std::call_once(once, [] { GDALAllRegister(); });
    CPLPushErrorHandler(CPLQuietErrorHandler);
    CPLErrorReset();
    CPLSetThreadLocalConfigOption("GDAL_PAM_ENABLED", "NO");
  }
  ~GdalSession() {
    CPLSetThreadLocalConfigOption("GDAL_PAM_ENABLED", nullptr);
    CPLPopErrorHandler();
  }
  GdalSession(const GdalSession&) = delete;
  GdalSession& operator=(const GdalSession&) = delete;

  /// GDAL's last error message, or `fallback` when it reported none.
  static std::string lastError(const char* fallback = "unknown GDAL error") {
    const char* m = CPLGetLastErrorMsg();
    return m && *m ? std::string(m) : std::string(fallback);
  }
  /// True when GDAL has reported an error (not a warning) since the session began or the last reset.
  static bool failed() { return CPLGetLastErrorType() >= CE_Failure; }
};

}  // namespace detail
}  // namespace gdal
}  // namespace dw
