// The console's two platforms, driving one loop around the same Console::frame() (console_app.cpp:
// a Platform gives each frame's input and presents it; run_console is the loop):
//   run_window    a GLFW window (OpenGL compatibility profile), keyboard, mouse and gamepad
//   run_headless  EGL with no display at a fixed time step, the scripted expert (or a script of input
//                 events) playing the operator, screenshots at named events
#pragma once

#include <string>

#include "ui/console.h"

namespace dd::ui {

struct ConsoleRunOptions {
  std::string screenshots;  // folder for query.png, takeover.png, update.png (and F12 shots); empty: none
  std::string script;       // headless: YAML list of input events (see README); empty: scripted operator
  int width = 1280, height = 800;
  int max_frames = 0;       // headless: stop after this many session frames (0: 20000)
};

/// Opens the window and runs until the operator quits. Returns the process exit code.
int run_window(ConsoleOptions options, const ConsoleRunOptions& run);

/// Runs headless until the three named screenshots are written (when a screenshot folder is given),
/// the session is done, or max_frames. Throws dd::Error on bad input (a malformed script).
int run_headless(ConsoleOptions options, const ConsoleRunOptions& run);

}  // namespace dd::ui
