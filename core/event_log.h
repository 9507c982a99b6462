// The session's event log: one JSON object per event (progress ticks left out), flushed line by line so
// that a crash keeps everything up to that moment. Shared by batch runs (queries.jsonl) and the
// console (session.jsonl).
#pragma once

#include <fstream>
#include <string>

#include "core/session.h"

namespace dd {

class EventLog {
 public:
  /// Appends to `path`; throws Error naming it when it cannot be opened.
  explicit EventLog(const std::string& path);
  /// Writes one line for `e`; throws Error naming the file when the write fails (disk full).
  void operator()(const SessionEvent& e);
  /// Writes a line for something that is not a session event (an operator's key, a save).
  void note(const std::string& event, const std::string& detail);
  const std::string& path() const { return path_; }

 private:
  void write(const std::string& line);
  std::string path_;
  std::ofstream f_;
};

}  // namespace dd
