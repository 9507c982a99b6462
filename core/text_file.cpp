#include "core/text_file.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/config.h"

namespace dd {

std::string read_text(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw Error(path + ": could not open");
  std::ostringstream text;
  text << f.rdbuf();
  return text.str();
}

void write_text(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
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
    std::filesystem::remove(tmp, ec);
    throw Error(path + ": could not move into place: " + ec.message());
  }
}

}  // namespace dd
