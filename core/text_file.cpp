#include "core/text_file.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

#include "core/config.h"

namespace dd {

std::string read_text(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw Error(path + ": could not open");
  std::ostringstream text;
  text << f.rdbuf();
  return text.str();
}

std::string temporary_path(const std::string& path) { return path + ".tmp." + std::to_string(::getpid()); }

void write_text(const std::string& path, const std::string& text) {
  // a temporary name of this process's own: processes writing the same file (eval --jobs) never
  // move each other's half-written file into place
  const std::string tmp = temporary_path(path);
  std::error_code ec;
  {
    std::ofstream f(tmp);
    f << text;
    f.flush();
    if (!f) {
      f.close();
      std::filesystem::remove(tmp, ec);
      throw Error(path + ": could not write (disk full or no permission?)");
    }
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    const std::string why = ec.message();
    std::filesystem::remove(tmp, ec);
    throw Error(path + ": could not move into place: " + why);
  }
}

}  // namespace dd
