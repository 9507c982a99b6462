#include "ui/commands.h"

#include <GLFW/glfw3.h>  // key codes only

#include <cctype>
#include <map>

#include "core/config.h"

namespace dd::ui {

const std::vector<Binding>& bindings() {
  using C = Command;
  static const std::vector<Binding> rows = {
      {C::kTakeOver, "take_over", {GLFW_KEY_T}, false, "T", "take over from the robot, or answer its query yourself", true},
      {C::kExpertAnswers, "expert_answers", {GLFW_KEY_E}, false, "E", "let the scripted expert answer the query", true},
      {C::kHandBack, "hand_back", {GLFW_KEY_H}, false, "H", "hand control back to the robot", true},
      {std::nullopt, "", {}, false, "Arrow keys", "drive: the target moves with the arrows (arm tasks: in the camera's ground plane)"},
      {std::nullopt, "", {}, false, "PageUp / PageDown", "arm tasks: raise / lower the target"},
      {C::kToggleGrip, "toggle_grip", {GLFW_KEY_G}, false, "G", "arm tasks: close / open the gripper"},
      {C::kNextCamera, "next_camera", {GLFW_KEY_C}, false, "C", "arm tasks: next camera (free, then the task's cameras)"},
      {std::nullopt, "", {}, false, "Mouse on an arm scene", "left drag orbits, right drag pans, wheel zooms; Shift + left drag moves the target"},
      {std::nullopt, "", {}, false, "Left mouse drag", "drag the target in the scene (takes over)"},
      {std::nullopt, "", {}, false, "Gamepad", "left stick drives; A take over, B hand back, X scripted expert, Start pause"},
      {C::kPause, "pause", {GLFW_KEY_SPACE}, false, "Space", "pause / resume"},
      {C::kStep, "step", {GLFW_KEY_N}, true, "N", "single step while paused"},
      {C::kReset, "reset", {GLFW_KEY_R}, false, "R", "reset: end this episode (expert steps are kept) and start the next", true},
      {C::kSave, "save", {GLFW_KEY_S}, false, "S", "save the policy now (the data set is saved after every episode)", true},
      {C::kToggleField, "toggle_field", {GLFW_KEY_F}, false, "F", "show / hide the diffusion-loss field (2-D)"},
      {C::kFaster, "faster", {GLFW_KEY_EQUAL, GLFW_KEY_KP_ADD}, false, "+", "faster"},
      {C::kSlower, "slower", {GLFW_KEY_MINUS, GLFW_KEY_KP_SUBTRACT}, false, "-", "slower"},
      {C::kScreenshot, "screenshot", {GLFW_KEY_F12}, false, "F12", "screenshot"},
      {C::kHelp, "help", {GLFW_KEY_F1, GLFW_KEY_SLASH}, false, "F1 or ?", "this help"},
      {C::kConfirm, "confirm", {GLFW_KEY_ENTER, GLFW_KEY_KP_ENTER}, false, "Enter", "confirm the open dialog (save the episode and quit)"},
      {C::kBack, "quit", {GLFW_KEY_ESCAPE}, false, "Esc", "close the dialog or this help, else quit (asks when an episode is in progress)"},
  };
  return rows;
}

const Binding& binding(Command c) {
  for (const Binding& b : bindings())
    if (b.command == c) return b;
  throw Error("console: command " + std::to_string(static_cast<int>(c)) + " has no row in the binding table");
}

std::optional<Command> command_for_key(int key, bool repeat) {
  for (const Binding& b : bindings())
    for (int k : b.keys)
      if (k == key && b.command && (!repeat || b.repeats)) return b.command;
  return std::nullopt;
}

Command command_named(const std::string& name, const std::string& where) {
  std::string names;
  for (const Binding& b : bindings()) {
    if (!b.command) continue;
    if (b.name == name) return *b.command;
    names += (names.empty() ? "" : ", ") + b.name;
  }
  throw Error(where + ": unknown command '" + name + "' (" + names + ")");
}

Command command_for_key_name(const std::string& name, const std::string& where) {
  static const std::map<std::string, int> named = {{"Space", GLFW_KEY_SPACE}, {"Escape", GLFW_KEY_ESCAPE}, {"Enter", GLFW_KEY_ENTER},
                                                   {"F1", GLFW_KEY_F1},       {"F12", GLFW_KEY_F12},       {"Plus", GLFW_KEY_EQUAL},
                                                   {"Minus", GLFW_KEY_MINUS}};
  int code = -1;
  if (auto it = named.find(name); it != named.end()) code = it->second;
  else if (name.size() == 1 && std::isalpha(static_cast<unsigned char>(name[0])))
    code = GLFW_KEY_A + (std::toupper(static_cast<unsigned char>(name[0])) - 'A');
  else
    throw Error(where + ": unknown key '" + name + "' (letters, Space, Escape, Enter, F1, F12, Plus, Minus)");
  if (auto c = command_for_key(code)) return *c;
  throw Error(where + ": key '" + name + "' does nothing in the console (F1 lists the keys)");
}

const std::vector<std::pair<int, Command>>& gamepad_bindings() {
  static const std::vector<std::pair<int, Command>> pad = {{GLFW_GAMEPAD_BUTTON_A, Command::kTakeOver},
                                                           {GLFW_GAMEPAD_BUTTON_B, Command::kHandBack},
                                                           {GLFW_GAMEPAD_BUTTON_X, Command::kExpertAnswers},
                                                           {GLFW_GAMEPAD_BUTTON_START, Command::kPause}};
  return pad;
}

}  // namespace dd::ui
