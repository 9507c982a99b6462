// The headless console's script: a YAML list of input events, e.g.
//   - {on: query, after: 8, do: take_over}  take over 8 frames after the first query
//   - {at: 40, hold: Left, frames: 10}      hold the Left direction from frame 40 for 10 frames
// Events give commands by name (ui/commands.h); `key: T` still works and means the key's command.
// Parsed on its own (yaml-cpp and the binding table only) so that a fuzzer can drive the parser.
#pragma once

#include <Eigen/Core>

#include "ui/commands.h"

#include <optional>
#include <string>
#include <vector>

namespace dd::ui {

struct ScriptEvent {
  int at = -1;          // frame, or -1 when triggered by `on`
  std::string on;       // query | update | takeover | episode
  int after = 0;        // frames after the trigger
  std::optional<Command> command;  // given once, at the start frame
  Eigen::Vector2d hold{0, 0};
  int frames = 1;       // how long a hold lasts
  int start = -1;       // resolved start frame
};

/// Reads a script file; throws dd::Error naming the file, the event and the field that is wrong.
std::vector<ScriptEvent> load_script(const std::string& path);

}  // namespace dd::ui
