// The panels: the loss plot, the control timeline, the session's numbers, the top bar, the key list
// and the quit dialog. They read the state and draw.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>

#include "ui/console_state.h"

namespace dd::ui::console {
namespace fs = std::filesystem;

// Expected loss (or the method's score) per decision on a log axis, with the threshold and violations.
void loss_plot(const Console::State& s, ImVec2 pos, ImVec2 size) {
  const MethodInfo& m = method_info(s.o.method);
  std::string title = m.score.empty() ? "Query score" : m.score;
  title[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(title[0])));
  begin_panel((title + " per decision###plot").c_str(), pos, size);
  const std::deque<DecisionPoint>& decisions = s.view.decisions();
  const DecisionPoint* last = decisions.empty() ? nullptr : &decisions.back();
  if (last) {
    ImGui::TextColored(ImVec4(0.55f, 0.75f, 1.f, 1.f), "score %.4g", last->score);
    ImGui::SameLine(0, 18);
    ImGui::TextColored(ImVec4(1.f, 0.70f, 0.15f, 1.f), "threshold %.4g (alpha %.2f)", last->threshold, s.o.config.method.alpha);
    ImGui::SameLine(0, 18);
    const int K = s.o.config.dagger.patience;
    ImGui::TextColored(last->run > 0 ? ImVec4(1.f, 0.35f, 0.35f, 1.f) : ImVec4(0.7f, 0.72f, 0.78f, 1.f), "in a row: %d / K=%d",
                       last->run, K);
  } else {
    ImGui::TextDisabled("no robot decisions yet: the expert demonstrates first");
  }
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const ImVec2 avail = ImGui::GetContentRegionAvail();
  const ImVec2 p0 = ImGui::GetCursorScreenPos();
  const float left = 52, bottom = 20;
  const ImVec2 a(p0.x + left, p0.y + 4), b(p0.x + avail.x - 6, p0.y + avail.y - bottom);
  dl->AddRectFilled(a, b, IM_COL32(14, 16, 21, 255), 4.f);
  ImGui::Dummy(avail);
  if (decisions.empty() || b.x - a.x < 20) {
    ImGui::End();
    return;
  }
  const int window = 120;
  const int n = static_cast<int>(decisions.size());
  const int first = std::max(0, n - window);
  float lo = INFINITY, hi = -INFINITY;
  for (int i = first; i < n; ++i) {
    const DecisionPoint& d = decisions[static_cast<size_t>(i)];
    for (float v : {d.score, d.threshold})
      if (v > 0 && std::isfinite(v)) {
        lo = std::min(lo, std::log10(v));
        hi = std::max(hi, std::log10(v));
      }
  }
  if (!std::isfinite(lo)) lo = -3, hi = 0;
  lo = std::floor(lo - 0.15f);
  hi = std::ceil(hi + 0.15f);
  if (hi - lo < 1) hi = lo + 1;
  auto X = [&](int i) { return a.x + 6 + (b.x - a.x - 12) * float(i - first) / float(std::max(window - 1, 1)); };
  auto Y = [&](float v) {
    const float l = std::log10(std::max(v, 1e-12f));
    return b.y - (b.y - a.y) * (l - lo) / (hi - lo);
  };
  for (int e = static_cast<int>(lo); e <= static_cast<int>(hi); ++e) {
    const float y = b.y - (b.y - a.y) * (e - lo) / (hi - lo);
    dl->AddLine(ImVec2(a.x, y), ImVec2(b.x, y), kGrid);
    char t[16];
    std::snprintf(t, sizeof t, "1e%d", e);
    dl->AddText(ImVec2(p0.x + 6, y - 8), kAxisText, t);
  }
  // episode boundaries
  for (int i = first + 1; i < n; ++i)
    if (decisions[static_cast<size_t>(i)].episode != decisions[static_cast<size_t>(i - 1)].episode)
      dl->AddLine(ImVec2(X(i) - 0.5f * (X(1) - X(0)), a.y), ImVec2(X(i) - 0.5f * (X(1) - X(0)), b.y), IM_COL32(255, 255, 255, 30));
  dl->PushClipRect(a, b, true);
  for (int i = first + 1; i < n; ++i) {
    const DecisionPoint& d0 = decisions[static_cast<size_t>(i - 1)];
    const DecisionPoint& d1 = decisions[static_cast<size_t>(i)];
    dl->AddLine(ImVec2(X(i - 1), Y(d0.threshold)), ImVec2(X(i), Y(d0.threshold)), kThresholdColor, 2.f);
    dl->AddLine(ImVec2(X(i), Y(d0.threshold)), ImVec2(X(i), Y(d1.threshold)), kThresholdColor, 2.f);
    if (d0.episode == d1.episode) dl->AddLine(ImVec2(X(i - 1), Y(d0.score)), ImVec2(X(i), Y(d1.score)), kScoreColor, 2.f);
  }
  for (int i = first; i < n; ++i) {
    const DecisionPoint& d = decisions[static_cast<size_t>(i)];
    if (d.violation) {
      dl->AddCircleFilled(ImVec2(X(i), Y(d.score)), 4.5f, kViolationRed);
      if (d.run >= s.o.config.dagger.patience) {
        dl->AddLine(ImVec2(X(i), a.y), ImVec2(X(i), b.y), IM_COL32(255, 176, 32, 120), 1.5f);
        dl->AddText(ImVec2(X(i) + 3, a.y + 2), kQueryAmber, "query");
      }
    } else {
      dl->AddCircleFilled(ImVec2(X(i), Y(d.score)), 2.5f, kScoreColor);
    }
  }
  dl->PopClipRect();
  char t[48];
  std::snprintf(t, sizeof t, "decision %d", decisions.back().index + 1);
  dl->AddText(ImVec2(b.x - ImGui::CalcTextSize(t).x, b.y + 2), kAxisText, t);
  dl->AddText(ImVec2(a.x, b.y + 2), kAxisText, "last 120 decisions; red: above threshold");
  ImGui::End();
}

// One row per episode, one cell per step, coloured by who was in control.
void timeline_view(const Console::State& s, ImVec2 pos, ImVec2 size) {
  begin_panel("Control per episode", pos, size);
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const ImVec2 avail = ImGui::GetContentRegionAvail();
  const ImVec2 p0 = ImGui::GetCursorScreenPos();
  ImGui::Dummy(avail);
  const float row_h = 15, gap = 4, label_w = 44;
  const int rows = std::max(1, static_cast<int>((avail.y - 18) / (row_h + gap)));
  const std::deque<Timeline>& timelines = s.view.timelines();
  const int n = static_cast<int>(timelines.size());
  const int first = std::max(0, n - rows);
  const int T = s.o.config.dagger.expert_time_limit > 0 ? s.o.config.dagger.expert_time_limit : 2 * s.o.config.dagger.time_limit;
  const float w = avail.x - label_w - 36;
  for (int r = first; r < n; ++r) {
    const Timeline& tl = timelines[static_cast<size_t>(r)];
    const float y = p0.y + (r - first) * (row_h + gap);
    char t[16];
    std::snprintf(t, sizeof t, "#%d", tl.episode);
    dl->AddText(ImVec2(p0.x, y), kAxisText, t);
    const float x0 = p0.x + label_w;
    dl->AddRectFilled(ImVec2(x0, y + 1), ImVec2(x0 + w, y + row_h - 1), IM_COL32(255, 255, 255, 12), 2.f);
    size_t i = 0;
    while (i < tl.steps.size()) {
      size_t j = i;
      while (j < tl.steps.size() && tl.steps[j] == tl.steps[i]) ++j;
      const float xa = x0 + w * float(i) / T, xb = x0 + w * std::min(float(j) / T, 1.f);
      dl->AddRectFilled(ImVec2(xa, y + 1), ImVec2(std::max(xb, xa + 1), y + row_h - 1), control_color(tl.steps[i]));
      i = j;
    }
    if (tl.ended)
      dl->AddText(ImVec2(x0 + w + 8, y), tl.success ? IM_COL32(110, 220, 140, 255) : IM_COL32(240, 90, 90, 255),
                  tl.success ? "ok" : "fail");
  }
  char t[64];
  std::snprintf(t, sizeof t, "steps (0 .. %d; the robot's limit T_L = %d)", T, s.o.config.dagger.time_limit);
  dl->AddText(ImVec2(p0.x + label_w, p0.y + avail.y - 16), kAxisText, t);
  const float xl = p0.x + label_w + w * float(s.o.config.dagger.time_limit) / T;
  dl->AddLine(ImVec2(xl, p0.y), ImVec2(xl, p0.y + std::min(n - first, rows) * (row_h + gap)), IM_COL32(226, 86, 74, 140), 1.f);
  ImGui::End();
}

void stat_row(const char* label, const std::string& value) {
  ImGui::TextDisabled("%s", label);
  ImGui::SameLine(0, 0);
  ImGui::SetCursorPosX(ImGui::GetColumnOffset() + 128);
  ImGui::TextUnformatted(value.c_str());
}

void session_view(const Console::State& s, ImVec2 pos, ImVec2 size) {
  begin_panel("Session", pos, size);
  const DaggerSession& se = *s.session;
  const DaggerConfig& d = s.o.config.dagger;
  const ConsoleCounts& counts = s.view.counts();
  const UpdateReport& report = s.view.last_report();
  ImGui::Columns(2, nullptr, false);
  stat_row("episode", std::to_string(se.episode()) + (se.in_episode() ? ", step " + std::to_string(s.env->steps()) : ""));
  stat_row("expert demos", std::to_string(se.expert_demos()) + " / " + std::to_string(d.final_demos) + " (N_f)");
  stat_row("interventions", std::to_string(se.interventions()) + " (update every " + std::to_string(d.demos_per_update) + ")");
  stat_row("queries", std::to_string(counts.queries) + ", time-outs " + std::to_string(counts.timeouts));
  stat_row("takeovers", std::to_string(counts.takeovers) + " by the operator");
  stat_row("robot alone", std::to_string(counts.robot_successes) + " / " + std::to_string(counts.robot_episodes) + " succeeded");
  ImGui::NextColumn();
  stat_row("updates", std::to_string(se.updates()));
  stat_row("training pairs", se.updates() ? std::to_string(report.pairs) : "-");
  char b[64];
  std::snprintf(b, sizeof b, "%.4g", report.threshold);
  stat_row("threshold", se.updates() ? b : "-");
  stat_row("train / thresh.", se.updates() ? fmt_seconds(report.train_s) + " / " + fmt_seconds(report.threshold_s) : "-");
  std::snprintf(b, sizeof b, "%.0f ms", s.view.last_decision_ms());
  stat_row("decision time", s.view.decisions().empty() ? "-" : b);
  if (s.o.fixed_step) std::snprintf(b, sizeof b, "fixed step %.0f ms", 1e3 / s.env->control_hz());
  else std::snprintf(b, sizeof b, "%.1f ms, speed x%g", s.frame_ms, s.o.speed);
  stat_row("frame", b);
  ImGui::Columns(1);
  ImGui::Separator();
  if (s.updating()) {
    char label[64];
    std::snprintf(label, sizeof label, "%s %d%%", to_string(s.worker.job()), static_cast<int>(s.worker.progress() * 100));
    ImGui::ProgressBar(s.worker.progress(), ImVec2(-1, 0), label);
  } else if (!s.worker.error().empty()) {
    ImGui::TextColored(ImVec4(1, 0.4f, 0.4f, 1), "worker failed: %s", s.worker.error().c_str());
  } else if (!s.status.empty()) {
    ImGui::TextWrapped("%s", s.status.c_str());
  } else {
    ImGui::TextDisabled("data set: %d episodes in %s, saved as each ends", s.writer->episodes(),
                        fs::path(s.writer->path()).filename().c_str());
  }
  ImGui::End();
}

void top_bar(const Console::State& s, ImVec2 size) {
  ImGui::SetNextWindowPos(ImVec2(0, 0));
  ImGui::SetNextWindowSize(ImVec2(size.x, 40));
  ImGui::PushStyleColor(ImGuiCol_WindowBg, ImVec4(0.07f, 0.075f, 0.09f, 1.f));
  ImGui::Begin("##top", nullptr, ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoSavedSettings);
  if (g_bold) ImGui::PushFont(g_bold);
  ImGui::TextUnformatted("diffdagger");
  if (g_bold) ImGui::PopFont();
  ImGui::SameLine(0, 16);
  ImGui::TextDisabled("task");
  ImGui::SameLine();
  ImGui::TextUnformatted(s.o.config.task.c_str());
  ImGui::SameLine(0, 16);
  ImGui::TextDisabled("method");
  ImGui::SameLine();
  ImGui::TextUnformatted(s.o.method.c_str());
  ImGui::SameLine(0, 24);
  // the control-mode pill
  const Control c = s.session->in_episode() ? s.session->actor() : Control::kRobot;
  std::string mode = s.session->done() ? "done" : s.updating() ? "updating" : s.awaiting ? "WAITING FOR THE OPERATOR" : control_label(c);
  if (s.paused && !s.session->done()) mode += " (paused)";
  const ImVec2 ts = ImGui::CalcTextSize(mode.c_str());
  const ImVec2 p = ImGui::GetCursorScreenPos();
  const ImU32 col = s.awaiting ? kViolationRed : s.updating() ? IM_COL32(90, 96, 110, 255) : control_color(c);
  ImGui::GetWindowDrawList()->AddRectFilled(ImVec2(p.x - 8, p.y - 2), ImVec2(p.x + ts.x + 8, p.y + ts.y + 2), col, 10.f);
  ImGui::TextUnformatted(mode.c_str());
  const char* hint = "F1 help";
  ImGui::SameLine(size.x - ImGui::CalcTextSize(hint).x - 16);
  ImGui::TextDisabled("%s", hint);
  ImGui::End();
  ImGui::PopStyleColor();
}

void help_overlay(const Console::State& s, ImVec2 size, std::vector<Command>& given) {
  if (!s.show_help) return;
  ImGui::SetNextWindowPos(ImVec2(size.x * 0.5f, size.y * 0.5f), 0, ImVec2(0.5f, 0.5f));
  ImGui::SetNextWindowBgAlpha(0.96f);
  bool open = true;
  ImGui::Begin("Keys", &open, ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoSavedSettings | ImGuiWindowFlags_NoCollapse);
  // the key column as wide as its widest entry (in the bold font it is drawn in), plus a gap
  const auto keys = console_keys();
  if (g_bold) ImGui::PushFont(g_bold);
  float key_width = 0;
  for (const auto& [k, what] : keys) key_width = std::max(key_width, ImGui::CalcTextSize(k.c_str()).x);
  if (g_bold) ImGui::PopFont();
  const float description_x = ImGui::GetCursorPosX() + key_width + 2 * ImGui::GetStyle().ItemSpacing.x + 8;
  for (const auto& [k, what] : keys) {
    if (g_bold) ImGui::PushFont(g_bold);
    ImGui::TextUnformatted(k.c_str());
    if (g_bold) ImGui::PopFont();
    ImGui::SameLine(description_x);
    ImGui::TextUnformatted(what.c_str());
  }
  ImGui::Separator();
  ImGui::TextDisabled("Queries %s. Every episode is saved to the data set as it ends.",
                      s.o.pause_on_query ? "pause the session until you answer" : "are answered by the scripted expert");
  ImGui::End();
  if (!open) given.push_back(Command::kHelp);  // its close button: the help command hides it
}

void close_dialog(const Console::State& s, std::vector<Command>& given) {
  if (!s.close_dialog) return;
  ImGui::OpenPopup("Quit?");
  if (ImGui::BeginPopupModal("Quit?", nullptr, ImGuiWindowFlags_AlwaysAutoResize)) {
    ImGui::Text("Episode %d is in progress with expert steps in it.", s.session->episode());
    ImGui::TextDisabled("Saving keeps them in the data set as a shortened episode.");
    // the buttons give what their keys give; the controller acts on it
    if (ImGui::Button("Save it and quit (Enter)")) {
      given.push_back(Command::kConfirm);
      ImGui::CloseCurrentPopup();
    }
    ImGui::SameLine();
    if (ImGui::Button("Keep working (Esc)")) {
      given.push_back(Command::kBack);
      ImGui::CloseCurrentPopup();
    }
    ImGui::EndPopup();
  }
}


}  // namespace dd::ui::console
