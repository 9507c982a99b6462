// Whole-file text I/O with the errors this project promises: a missing file and a failed write both
// name the file, and a write goes through a temporary file and a rename, so a full disk or a kill
// mid-write never leaves a half-written file where a good one was.
#pragma once

#include <string>

namespace dd {

/// The file's contents; throws Error naming the file when it cannot be opened.
std::string read_text(const std::string& path);

/// Replaces the file with `text` atomically (temporary_path(path), then a rename). Throws Error naming
/// the file and the reason when it cannot be written or moved into place; the old file, if any, is
/// left as it was.
void write_text(const std::string& path, const std::string& text);

/// The temporary file write_text() writes first: path + ".tmp." + this process's id.
std::string temporary_path(const std::string& path);

}  // namespace dd
