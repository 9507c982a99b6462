// The quick 2-D demo writes every file, its CSV has all three regions for both metrics, and its
// pictures are readable images.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <fstream>
#include <set>
#include <sstream>

#include "app/demo2d.h"
#include "ui/image_io.h"

namespace dd::app {

TEST(Demo2d, QuickRunWritesEveryFile) {
  namespace fs = std::filesystem;
  Demo2dOptions o;
  o.apply_quick();
  o.out = (fs::temp_directory_path() / ("dd_demo2d_" + std::to_string(::getpid()))).string();
  fs::remove_all(o.out);
  const Demo2dResult r = run_demo2d(o);

  for (const char* f : {"fig2_regions.csv", "fig2_regions.png", "loss_field.png", "summary.md", "fig2_loss_by_timestep.csv",
                        "fig2_loss_by_timestep.png"})
    EXPECT_TRUE(fs::exists(o.out + "/" + f)) << f;
  EXPECT_EQ(r.files.size(), 6u);
  {  // the loss by timestep: every space but the target's own, every region, every timestep
    std::ifstream t_csv(o.out + "/fig2_loss_by_timestep.csv");
    std::string line;
    std::getline(t_csv, line);
    EXPECT_EQ(line, "space,region,t,mean_loss");
    std::map<std::string, int> rows;
    while (std::getline(t_csv, line)) ++rows[line.substr(0, line.find(','))];
    EXPECT_EQ(rows.size(), 3u);
    for (const auto& [space, n] : rows) EXPECT_EQ(n, 3 * 16) << space;  // 3 regions x T_d
  }

  std::ifstream csv(o.out + "/fig2_regions.csv");
  std::string header;
  std::getline(csv, header);
  EXPECT_EQ(header, "region,metric,mean,std,n");
  std::set<std::string> seen;
  std::string line;
  while (std::getline(csv, line)) {
    std::stringstream ss(line);
    std::string region, metric, mean, sd, n;
    std::getline(ss, region, ',');
    std::getline(ss, metric, ',');
    std::getline(ss, mean, ',');
    std::getline(ss, sd, ',');
    std::getline(ss, n, ',');
    EXPECT_GT(std::stod(mean), 0.0) << line;
    EXPECT_EQ(std::stoi(n), o.runs) << line;
    seen.insert(region + "/" + metric);
  }
  for (const char* region : {"id_um", "id_mm", "ood"})
    for (const char* metric : {"ensemble_std", "diffusion_loss"})
      EXPECT_TRUE(seen.count(std::string(region) + "/" + metric)) << region << " " << metric;

  for (const char* png : {"fig2_regions.png", "loss_field.png"}) {
    const ui::Image img = ui::read_png(o.out + "/" + png);
    EXPECT_GT(img.width, 600) << png;
    EXPECT_GT(img.height, 300) << png;
  }
  std::ifstream md(o.out + "/summary.md");
  const std::string summary((std::istreambuf_iterator<char>(md)), std::istreambuf_iterator<char>());
  EXPECT_NE(summary.find(r.claim_holds ? "claim holds" : "claim does not hold"), std::string::npos);
  fs::remove_all(o.out);
}

}  // namespace dd::app
