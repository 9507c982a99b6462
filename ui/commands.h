// What the operator can ask of the console, and the one table that binds keys and gamepad buttons to
// it. The window turns key presses into commands through this table, headless scripts name commands
// (`do: take_over`), the controller executes commands (never key codes), and the help overlay and the
// README's key list are generated from the same rows.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace dd::ui {

enum class Command {
  kTakeOver,       // take over from the robot, or answer its query yourself
  kExpertAnswers,  // let the scripted expert answer the query
  kHandBack,       // hand control back to the robot
  kReset,          // end this episode and start the next
  kSave,           // save the policy now
  kPause,          // pause / resume
  kStep,           // one step while paused
  kToggleGrip,     // arm tasks: close / open the gripper
  kNextCamera,     // arm tasks: next camera
  kToggleField,    // 2-D: the diffusion-loss field
  kFaster,
  kSlower,
  kHelp,
  kScreenshot,
  kConfirm,        // Enter: confirm the open dialog
  kBack,           // Esc: close the dialog or the help, else quit
};

/// One row of the binding table: a command with the keys that give it, or (no command) a continuous
/// input the platform reads itself (arrow keys, mouse, stick), listed for the help only.
struct Binding {
  std::optional<Command> command;
  std::string name;         // the command's name in scripts (empty for inputs)
  std::vector<int> keys;    // GLFW key codes
  bool repeats = false;     // a held key repeats the command
  std::string keys_label;   // how the help writes the keys
  std::string description;
  bool changes_session = false;  // waits for a decision being computed before it acts
};

/// Every row, in the order the help lists them.
const std::vector<Binding>& bindings();
/// The row of a command.
const Binding& binding(Command c);
/// The command a key press (or, with `repeat`, a key repeat) gives, if any.
std::optional<Command> command_for_key(int key, bool repeat = false);
/// The command a script names; throws dd::Error naming `where` and listing the names.
Command command_named(const std::string& name, const std::string& where);
/// The command a named key gives (letters, Space, Escape, Enter, F1, F12, Plus, Minus): scripts
/// written with `key:`. Throws dd::Error naming `where` when the key is unknown or unbound.
Command command_for_key_name(const std::string& key, const std::string& where);
/// Gamepad buttons (GLFW_GAMEPAD_BUTTON_*) and their commands.
const std::vector<std::pair<int, Command>>& gamepad_bindings();

}  // namespace dd::ui
