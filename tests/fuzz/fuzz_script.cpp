// libFuzzer: the headless console's script of input events (gui --headless --script FILE).
#include "tests/fuzz/fuzz_common.h"
#include "ui/script.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = dd::fuzz::input_file(data, size, "script.yaml");
  dd::fuzz::expect_clean([&] { dd::ui::load_script(path); });
  return 0;
}
