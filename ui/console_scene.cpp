// The scene view: the 2-D toy drawn with Scene2d, or the arm's MuJoCo view through a texture, with
// the overlays (query banner, update progress, driving hint). Draws only; mouse input on the arm
// scene moves the camera or the operator's target.
#include <GL/gl.h>

#include <algorithm>
#include <cmath>

#include "ui/console_state.h"

namespace dd::ui::console {

void begin_panel(const char* title, ImVec2 pos, ImVec2 size, ImGuiWindowFlags extra) {
  ImGui::SetNextWindowPos(pos);
  ImGui::SetNextWindowSize(size);
  ImGui::Begin(title, nullptr,
               ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse | ImGuiWindowFlags_NoSavedSettings | extra);
}

namespace {

// A 2-D task from above: arena, start square, goal, the newest demonstrations, obstacles, the path so
// far coloured by who acted, the robot's planned chunk and the operator's target.
void draw_plane(Console::State& s, const PlaneScene& p, ImVec2 size) {
  Scene2d& sc = *s.scene;
  const int px = std::max(64, static_cast<int>(std::min(size.x, size.y)));
  sc.resize(px, px);
  const double half = p.half;
  sc.begin({0, 0}, half + 0.06, {0.075f, 0.080f, 0.095f, 1.f});
  sc.rect({-half - 0.04, -half - 0.04}, {half + 0.04, half + 0.04}, {0.30f, 0.32f, 0.37f, 1.f});  // walls
  sc.rect({-half, -half}, {half, half}, {0.145f, 0.155f, 0.180f, 1.f});                            // floor
  if (s.show_field && s.field_valid)
    sc.heat(s.field, s.field_n, s.field_n, {-half, -half}, {half, half}, 0.85f);
  const Eigen::Vector2d c = p.start_center, sh(p.start_half, p.start_half), sv(p.start_half, -p.start_half);
  sc.stroke({c - sh, c + sv, c + sh, c - sv, c - sh}, 1.5, {1, 1, 1, 0.35f});
  sc.disc(p.goal.center, p.goal.radius, {0.30f, 0.78f, 0.45f, 0.35f});
  sc.ring(p.goal.center, p.goal.radius, 2.0, {0.35f, 0.85f, 0.50f, 0.9f});
  // demonstrations (the newest 40)
  const auto& demos = s.session->expert_data();
  const size_t from = demos.size() > 40 ? demos.size() - 40 : 0;
  for (size_t d = from; d < demos.size(); ++d) {
    std::vector<Eigen::Vector2d> pts;
    for (Eigen::Index t = 0; t < demos[d].obs.rows(); ++t)
      if (const auto q = s.env->observed_point(demos[d].obs.row(t).transpose())) pts.emplace_back(q->head<2>());
    sc.stroke(pts, 1.6, {0.80f, 0.84f, 0.95f, 0.22f});
  }
  for (const PlaneScene::Disc& o : p.obstacles) sc.disc(o.center, o.radius, {0.40f, 0.42f, 0.49f, 1.f}, 0.06f);
  // the executed path, coloured by who was in control
  const auto& path = s.view.path();
  for (size_t i = 1; i < path.size(); ++i)
    sc.stroke({path[i - 1].first, path[i].first}, 3.0, to_rgba(control_color(path[i].second)));
  // the planned chunk: targets ahead of the robot, executed ones faded
  if (s.session->control() == Control::kRobot) {
    std::vector<Eigen::Vector2d> pts;
    for (const Eigen::Vector3d& q : s.env->action_points(s.session->chunk())) pts.emplace_back(q.head<2>());
    if (!pts.empty()) {
      sc.stroke(pts, 1.5, {0.55f, 0.85f, 1.f, 0.6f});
      for (size_t r = 0; r < pts.size(); ++r)
        sc.dot(pts[r], 3.0, {0.55f, 0.85f, 1.f, static_cast<int>(r) < s.session->chunk_pos() ? 0.3f : 0.95f});
    }
  }
  const Eigen::Vector2d agent = p.agent.center;
  if (s.operator_drives() && !s.o.scripted_operator) {
    const Eigen::Vector2d t = s.dragging ? s.drag_target : Eigen::Vector2d(agent + 0.2 * s.jog);
    sc.stroke({agent, t}, 1.5, to_rgba(control_color(Control::kOperator), 0.8f));
    sc.ring(t, 0.035, 2.0, to_rgba(control_color(Control::kOperator)));
  }
  const Control now = s.session->in_episode() ? s.session->actor() : s.view.last_actor();
  sc.disc(agent, p.agent.radius + 0.012, {1, 1, 1, 0.9f});
  sc.disc(agent, p.agent.radius, to_rgba(control_color(now)));
  sc.render();
}

// A physics scene through MuJoCo's renderer: the free camera (orbit, pan, zoom with the mouse) or one
// of the task's cameras; the robot's planned points (TCP targets) and the operator's target as markers.
void draw_mujoco(Console::State& s, ImVec2 origin, float side) {
  const mjData_* d = s.physics->data;
  std::vector<Marker> markers;
  if (s.session->control() == Control::kRobot) {
    const std::vector<Eigen::Vector3d> points = s.env->action_points(s.session->chunk());
    for (size_t r = 0; r < points.size(); ++r) {
      const float a = static_cast<int>(r) < s.session->chunk_pos() ? 0.25f : 0.9f;
      markers.push_back({{points[r].x(), points[r].y(), points[r].z()}, 0.006, {0.45f, 0.8f, 1.f, a}});
    }
  }
  if (s.operator_drives() && !s.o.scripted_operator)
    if (const auto t = s.teleop->target()) markers.push_back({{t->x(), t->y(), t->z()}, 0.012, {0.7f, 0.42f, 0.91f, 0.9f}});
  const int px = std::max(64, static_cast<int>(side));
  // MuJoCo's renderer is the costly part of a frame on a software GL: render only when the picture
  // changes (the simulation stepped, the camera or a marker moved), not while a policy update runs
  std::vector<double> key = {double(s.session->episode()), double(s.env->steps()), s.free_cam.lookat[0], s.free_cam.lookat[1], s.free_cam.lookat[2], s.free_cam.distance,
                             s.free_cam.azimuth, s.free_cam.elevation, double(s.camera), double(px), double(markers.size())};
  for (const Marker& m : markers) key.insert(key.end(), {m.pos[0], m.pos[1], m.pos[2], double(m.rgba[3])});
  if (key != s.mj_key) {
    s.mj_key = key;
    const Image img = s.camera < 0 ? s.mjview->free(d, s.free_cam, px, px, markers)
                                   : s.mjview->camera_view(d, s.cameras[static_cast<size_t>(s.camera)], px, px, markers);
    glBindTexture(GL_TEXTURE_2D, s.mj_tex);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, img.width, img.height, 0, GL_RGBA, GL_UNSIGNED_BYTE, img.rgba.data());
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  }
  ImGui::SetCursorScreenPos(origin);
  ImGui::Image(reinterpret_cast<ImTextureID>(static_cast<intptr_t>(s.mj_tex)), ImVec2(side, side));
  const bool hovered = ImGui::IsItemHovered();
  ImGuiIO& io = ImGui::GetIO();
  if (hovered && s.camera < 0) {
    if (io.KeyShift && ImGui::IsMouseDown(ImGuiMouseButton_Left) && !s.busy()) {
      // Shift + drag: the operator's target follows the point under the mouse
      const ImVec2 m = ImGui::GetMousePos();
      double p[3];
      if (s.mjview->select(d, (m.x - origin.x) / side, 1.0 - (m.y - origin.y) / side, 1.0, p)) {
        s.drag_target = Eigen::Vector2d(p[0], p[1]);
        if (!s.dragging) {
          s.dragging = true;
          if (!s.operator_drives()) s.from_views.push_back(Command::kTakeOver);  // the controller acts on it
        }
      }
    } else if (ImGui::IsMouseDragging(ImGuiMouseButton_Left)) {
      s.free_cam.azimuth -= io.MouseDelta.x * 0.3;
      s.free_cam.elevation = std::clamp(s.free_cam.elevation - io.MouseDelta.y * 0.3, -89.0, -2.0);
    } else if (ImGui::IsMouseDragging(ImGuiMouseButton_Right)) {
      const double az = s.free_cam.azimuth * M_PI / 180, k = s.free_cam.distance * 0.0015;
      s.free_cam.lookat[0] += (-std::sin(az) * io.MouseDelta.x - std::cos(az) * io.MouseDelta.y) * k;
      s.free_cam.lookat[1] += (std::cos(az) * io.MouseDelta.x - std::sin(az) * io.MouseDelta.y) * k;
    }
    if (io.MouseWheel != 0) s.free_cam.distance = std::clamp(s.free_cam.distance * (1.0 - 0.1 * io.MouseWheel), 0.3, 5.0);
  }
  if (!ImGui::IsMouseDown(ImGuiMouseButton_Left)) s.dragging = false;
  // which camera, top-left
  const char* cam = s.camera < 0 ? "free camera (C: next)" : s.cameras[static_cast<size_t>(s.camera)].c_str();
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const ImVec2 ts = ImGui::CalcTextSize(cam);
  dl->AddRectFilled(ImVec2(origin.x + 8, origin.y + side - 30), ImVec2(origin.x + 20 + ts.x, origin.y + side - 8),
                    IM_COL32(10, 12, 16, 170), 4.f);
  dl->AddText(ImVec2(origin.x + 14, origin.y + side - 27), IM_COL32(220, 224, 232, 230), cam);
}


}  // namespace

void scene_view(Console::State& s, ImVec2 pos, ImVec2 size) {
  begin_panel("Scene", pos, size, ImGuiWindowFlags_NoScrollbar);
  const ImVec2 avail = ImGui::GetContentRegionAvail();
  const float side = std::min(avail.x, avail.y - 58);  // room for the legend below
  const ImVec2 origin(ImGui::GetCursorScreenPos().x + (avail.x - side) * 0.5f, ImGui::GetCursorScreenPos().y);
  ImDrawList* dl = ImGui::GetWindowDrawList();
  if (const std::optional<PlaneScene> plane = s.env->plane()) {
    draw_plane(s, *plane, ImVec2(side, side));
    ImGui::SetCursorScreenPos(origin);
    ImGui::Image(reinterpret_cast<ImTextureID>(static_cast<intptr_t>(s.scene->texture())), ImVec2(side, side), ImVec2(0, 1),
                 ImVec2(1, 0));
    // dragging a target takes over and steers
    if (ImGui::IsItemHovered() && ImGui::IsMouseDown(ImGuiMouseButton_Left) && !s.busy()) {
      const ImVec2 m = ImGui::GetMousePos();
      const double k = s.scene->width() / double(side);
      s.drag_target = s.scene->pixel_to_world((m.x - origin.x) * k, (m.y - origin.y) * k);
      if (!s.dragging) {
        s.dragging = true;
        if (!s.operator_drives()) s.from_views.push_back(Command::kTakeOver);  // the controller acts on it
      }
    } else if (!ImGui::IsMouseDown(ImGuiMouseButton_Left)) {
      s.dragging = false;
    }
  } else if (s.physics) {
    draw_mujoco(s, origin, side);
  } else {
    dl->AddText(origin, kAxisText, "no renderer for this task");
  }
  // legend and key hints below the scene
  {
    ImVec2 p(origin.x + 4, origin.y + side + 10);
    const Control order[] = {Control::kRobot, Control::kExpertQuery, Control::kOperator, Control::kExpertTimeout,
                             Control::kExpertDemo};
    for (Control c : order) {
      dl->AddRectFilled(ImVec2(p.x, p.y + 4), ImVec2(p.x + 12, p.y + 14), control_color(c), 2.f);
      dl->AddText(ImVec2(p.x + 17, p.y), IM_COL32(220, 224, 232, 230), control_label(c));
      p.x += 22 + ImGui::CalcTextSize(control_label(c)).x + 12;
    }
    dl->AddText(ImVec2(origin.x + 4, origin.y + side + 34), kAxisText,
                s.show_field && s.field_valid
                    ? "loss field (the method's score at rest, log scale): dark = familiar, bright = unfamiliar"
                    : "T take over   H hand back   E scripted expert   Space pause   F loss field   F1 all keys");
  }
  // the query banner: the robot waits for the operator
  if (s.awaiting) {
    const float w = side - 40, h = 92;
    const ImVec2 a(origin.x + 20, origin.y + 20), b(a.x + w, a.y + h);
    const bool blink = std::fmod(ImGui::GetTime(), 1.0) < 0.5 || s.o.fixed_step;
    dl->AddRectFilled(a, b, IM_COL32(200, 40, 40, blink ? 235 : 200), 8.f);
    dl->AddRect(a, b, IM_COL32(255, 210, 120, 255), 8.f, 0, 3.f);
    if (g_big) ImGui::PushFont(g_big);
    const char* title = "THE ROBOT ASKS FOR HELP";
    const ImVec2 ts = ImGui::CalcTextSize(title);
    dl->AddText(ImVec2(a.x + (w - ts.x) * 0.5f, a.y + 12), IM_COL32(255, 255, 255, 255), title);
    if (g_big) ImGui::PopFont();
    char line[160];
    const DecisionPoint* d = s.view.decisions().empty() ? nullptr : &s.view.decisions().back();
    const float score = d ? d->score : 0.f, threshold = d ? d->threshold : 0.f;
    const int K = s.o.config.dagger.patience;
    const MethodInfo& m = method_info(s.o.method);
    if (d && d->reason == QueryReason::kRisk)
      std::snprintf(line, sizeof line, "risk: the critic's success estimate %.2f is below its bound", d->risk_q);
    else
      std::snprintf(line, sizeof line, "%s%s %.3g above the threshold %.3g for %d decisions in a row", m.learns_risk ? "novelty: " : "",
                    m.score_word.c_str(), score, threshold, K);
    ImVec2 ls = ImGui::CalcTextSize(line);
    dl->AddText(ImVec2(a.x + (w - ls.x) * 0.5f, a.y + 44), IM_COL32(255, 235, 220, 255), line);
    const char* keys = s.o.scripted_operator ? "the scripted operator takes over shortly"
                                             : "T: take over    E: scripted expert    Esc: quit";
    ls = ImGui::CalcTextSize(keys);
    dl->AddText(ImVec2(a.x + (w - ls.x) * 0.5f, a.y + 66), IM_COL32(255, 255, 255, 255), keys);
  } else if (s.updating()) {
    const float w = 300, h = 54;
    const ImVec2 a(origin.x + (side - w) * 0.5f, origin.y + 20), b(a.x + w, a.y + h);
    dl->AddRectFilled(a, b, IM_COL32(18, 22, 30, 225), 8.f);
    char line[96];
    std::snprintf(line, sizeof line, "%s %d%%", s.worker.job() == WorkerJob::kUpdate ? "Updating the policy" : "Computing the loss field",
                  static_cast<int>(s.worker.progress() * 100));
    dl->AddText(ImVec2(a.x + 14, a.y + 8), IM_COL32(230, 234, 240, 255), line);
    dl->AddRectFilled(ImVec2(a.x + 14, a.y + 32), ImVec2(b.x - 14, a.y + 42), IM_COL32(60, 66, 80, 255), 3.f);
    dl->AddRectFilled(ImVec2(a.x + 14, a.y + 32), ImVec2(a.x + 14 + (w - 28) * s.worker.progress(), a.y + 42), IM_COL32(72, 132, 235, 255),
                      3.f);
  } else if (s.operator_drives() && !s.o.scripted_operator) {
    const char* t = "You are driving: arrow keys, or drag the target.  H hands back to the robot.";
    const ImVec2 ts = ImGui::CalcTextSize(t);
    dl->AddRectFilled(ImVec2(origin.x + (side - ts.x) * 0.5f - 10, origin.y + 14),
                      ImVec2(origin.x + (side + ts.x) * 0.5f + 10, origin.y + 40), IM_COL32(120, 70, 170, 220), 6.f);
    dl->AddText(ImVec2(origin.x + (side - ts.x) * 0.5f, origin.y + 19), IM_COL32(255, 255, 255, 255), t);
  }
  if (s.show_field && !s.field_valid && !s.updating()) {
    const char* t = s.session->updates() == 0 ? "the loss field needs a trained policy" : "press F again to compute the field";
    dl->AddText(ImVec2(origin.x + 12, origin.y + 12), kAxisText, t);
  }
  ImGui::End();
}

}  // namespace dd::ui::console
