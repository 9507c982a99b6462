// The 2-D demo writes every file, its CSVs have every region, measure and seed, and its pictures are
// readable images.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <fstream>
#include <set>
#include <sstream>

#include "app/demo2d.h"
#include "core/text_file.h"
#include "ui/image_io.h"

namespace dd::app {

// Two seeds of a run smaller than --quick: each seed's folder has every file, and the summary over
// seeds has every score.
TEST(Demo2d, SeedsWriteEveryFileAndASummaryOverThem) {
  namespace fs = std::filesystem;
  Demo2dOptions base;
  base.apply_quick();
  base.demos = 20;
  base.train_steps = 120;
  base.runs = 10;
  base.grid = 8;
  base.loss_samples = 64;
  base.field_loss_samples = 32;
  base.seeds = 2;
  base.out = (fs::temp_directory_path() / ("dd_demo2d_" + std::to_string(::getpid()))).string();
  fs::remove_all(base.out);
  const std::vector<Demo2dResult> results = run_demo2d_seeds(base);
  ASSERT_EQ(results.size(), 2u);
  for (const char* f : {"summary.md", "fig2_seeds.csv"}) EXPECT_TRUE(fs::exists(base.out + "/" + f)) << f;
  {  // one row per seed and score
    std::ifstream seeds_csv(base.out + "/fig2_seeds.csv");
    std::string line;
    std::getline(seeds_csv, line);
    EXPECT_EQ(line, "seed,space,ensemble_mm_over_um,loss_ood_over_mm,loss_ood_over_um,claim");
    std::set<std::string> rows;
    while (std::getline(seeds_csv, line)) rows.insert(line.substr(0, line.find(',', line.find(',') + 1)));
    EXPECT_EQ(rows, (std::set<std::string>{"0,epsilon", "0,v", "0,sample", "0,epsilon_low", "0,v_low", "0,sample_low", "1,epsilon",
                                           "1,v", "1,sample", "1,epsilon_low", "1,v_low", "1,sample_low"}));
  }
  const Demo2dResult& r = results[0];
  Demo2dOptions o = base;
  o.out = base.out + "/seed_0";
  for (const char* group : {"id_um", "id_mm", "ood", "along_2", "along_4", "along_8"})
    for (const char* measure : {"ensemble_std", "loss_target", "loss_epsilon", "loss_v", "loss_sample", "loss_epsilon_low", "loss_v_low",
                                "loss_sample_low"})
      EXPECT_GT(r.means.count(std::string(measure) + "/" + group), 0u) << measure << "/" << group;
  // the same states scored differently per seed: the two runs are not copies of each other
  EXPECT_NE(results[0].means.at("loss_target/ood"), results[1].means.at("loss_target/ood"));
  {  // run again: both seeds are read back, not rerun, and the summary over them is the same
    const std::string summary = read_text(base.out + "/summary.md");
    fs::remove(base.out + "/seed_1/loss_field.png");  // a rerun would write it again
    const std::vector<Demo2dResult> again = run_demo2d_seeds(base);
    EXPECT_FALSE(fs::exists(base.out + "/seed_1/loss_field.png"));
    EXPECT_EQ(read_text(base.out + "/summary.md"), summary);
    EXPECT_NEAR(again[1].means.at("loss_epsilon/along_4"), results[1].means.at("loss_epsilon/along_4"),
                1e-5 * results[1].means.at("loss_epsilon/along_4"));
  }

  for (const char* f : {"fig2_regions.csv", "fig2_regions.png", "loss_field.png", "summary.md", "fig2_loss_by_timestep.csv",
                        "fig2_loss_by_timestep.png", "fig2_along_paths.csv"})
    EXPECT_TRUE(fs::exists(o.out + "/" + f)) << f;
  EXPECT_EQ(r.files.size(), 7u);
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
  {  // along the paths: 6 groups x (ensemble + 3 spaces, over all timesteps and over the low-noise quarter)
    std::ifstream a_csv(o.out + "/fig2_along_paths.csv");
    std::string line;
    std::getline(a_csv, line);
    EXPECT_EQ(line, "group,steps_along,measure,mean,std,n");
    int rows = 0;
    while (std::getline(a_csv, line)) ++rows;
    EXPECT_EQ(rows, 6 * 7);
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
  fs::remove_all(base.out);
}

}  // namespace dd::app
