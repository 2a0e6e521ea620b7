// CSV time series (core/output.hpp): a header of column names, then one row per call, flushed at once, every
// double with the digits it needs to read back exactly.
#include <cerrno>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/output.hpp"
#include "output_files.hpp"

namespace lbdem::io {

namespace fs = std::filesystem;
using namespace detail;

// ---------------------------------------------------------------------------
// TimeSeries
// ---------------------------------------------------------------------------
TimeSeries::TimeSeries(const std::string& path, std::vector<std::string> columns) : path_(path), ncols_(columns.size()) {
  if (columns.empty()) throw Error("TimeSeries '" + path + "': no columns given");
  const fs::path p(path);
  record_in_manifest(p.has_parent_path() ? p.parent_path() : fs::path("."), p.filename().string());
  errno = 0;
  out_.open(path, std::ios::trunc);
  if (!out_) io_fail(path, "cannot open the time series", errno);
  out_.precision(std::numeric_limits<double>::max_digits10);
  for (std::size_t i = 0; i < columns.size(); ++i) out_ << (i ? "," : "") << columns[i];
  out_ << '\n';
  out_.flush();
  if (!out_) io_fail(path, "writing the header of the time series failed", errno);
}

void TimeSeries::append(const std::vector<double>& values) {
  if (!out_.is_open()) throw Error("TimeSeries::append on a series that was never opened");
  if (values.size() != ncols_)
    throw Error("TimeSeries::append: got " + std::to_string(values.size()) + " values for " + std::to_string(ncols_) +
                " columns");
  errno = 0;
  for (std::size_t i = 0; i < values.size(); ++i) out_ << (i ? "," : "") << values[i];
  out_ << '\n';
  out_.flush();
  if (!out_) io_fail(path_, "writing a time-series row failed", errno);
}

}  // namespace lbdem::io
