// SPDX-License-Identifier: GPL-3.0-or-later
//
// Human-readable tables and machine-readable JSON for CLI output.
#ifndef HDRSTEREO_CLIENTS_CLI_OUTPUT_H_
#define HDRSTEREO_CLIENTS_CLI_OUTPUT_H_

#include <google/protobuf/message.h>
#include <google/protobuf/timestamp.pb.h>

#include <ostream>
#include <string>
#include <utility>
#include <vector>

namespace hdrstereo::cli {

// Columns padded to their widest cell; the header is printed as given.
class Table {
 public:
  explicit Table(std::vector<std::string> header) : rows_{std::move(header)} {}
  void AddRow(std::vector<std::string> row) { rows_.push_back(std::move(row)); }
  void Print(std::ostream& out) const;

 private:
  std::vector<std::vector<std::string>> rows_;
};

// "key   value" lines with keys padded to the longest.
void PrintFields(
    std::ostream& out,
    const std::vector<std::pair<std::string, std::string>>& fields);

// The message as JSON with the .proto field names, every field present.
void PrintJson(std::ostream& out, const google::protobuf::Message& message);

// Local time, "2026-11-23 18:04:05".
std::string FormatTime(const google::protobuf::Timestamp& time);

}  // namespace hdrstereo::cli

#endif  // HDRSTEREO_CLIENTS_CLI_OUTPUT_H_
