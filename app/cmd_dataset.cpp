// diffdagger dataset info | export | merge
#include <fmt/format.h>

#include <filesystem>
#include <fstream>

#include "app/commands.h"
#include "core/config.h"
#include "core/dataset.h"

namespace dd::app {

Command add_dataset(CLI::App& app) {
  auto* cmd = app.add_subcommand("dataset", "Inspect, export and merge HDF5 data sets (robomimic layout)");
  cmd->require_subcommand(1);
  auto files = std::make_shared<std::vector<std::string>>();
  auto out = std::make_shared<std::string>();
  auto* info = cmd->add_subcommand("info", "Episodes, steps, interventions and env_args of each file");
  info->add_option("files", *files, "data set files")->required()->check(CLI::ExistingFile);
  auto* exp = cmd->add_subcommand("export", "Write every step as a CSV row");
  exp->add_option("file", *files, "data set file")->required()->check(CLI::ExistingFile);
  exp->add_option("--out", *out, "CSV file")->required();
  auto* merge = cmd->add_subcommand("merge", "Concatenate data sets of the same task into a new file");
  merge->add_option("files", *files, "data set files")->required()->check(CLI::ExistingFile);
  merge->add_option("--out", *out, "new data set file (must not exist)")->required();

  return [=] {
    if (info->parsed()) {
      for (const auto& f : *files) {
        const DatasetInfo i = dataset_info(f);
        fmt::print("{}\n  episodes {}  steps {}  successes {}  intervention steps {} ({:.1f}%)\n  obs dim {}  action dim {}\n  env_args {}\n",
                   f, i.episodes, i.total, i.successes, i.intervention_steps,
                   i.total ? 100.0 * static_cast<double>(i.intervention_steps) / static_cast<double>(i.total) : 0.0, i.obs_dim,
                   i.action_dim, i.env_args);
      }
      return 0;
    }
    if (exp->parsed()) {
      const auto eps = read_dataset(files->front());
      std::ofstream csv(*out);
      if (!csv) throw Error(*out + ": could not open for writing");
      csv << "episode,step,source,success";
      if (!eps.empty()) {
        for (int j = 0; j < eps[0].obs.cols(); ++j) csv << ",obs_" << j;
        for (int j = 0; j < eps[0].actions.cols(); ++j) csv << ",action_" << j;
      }
      csv << ",reward,done,intervention,actor\n";
      for (size_t e = 0; e < eps.size(); ++e) {
        const auto& ep = eps[e];
        for (int t = 0; t < ep.steps(); ++t) {
          csv << e << ',' << t << ',' << ep.source << ',' << int(ep.success);
          for (int j = 0; j < ep.obs.cols(); ++j) csv << ',' << ep.obs(t, j);
          for (int j = 0; j < ep.actions.cols(); ++j) csv << ',' << ep.actions(t, j);
          csv << ',' << ep.rewards[static_cast<size_t>(t)] << ',' << int(ep.dones[static_cast<size_t>(t)]) << ','
              << (ep.intervention.empty() ? 0 : int(ep.intervention[static_cast<size_t>(t)])) << ','
              << (ep.actor.empty() ? "" : kActorLabels[ep.actor[static_cast<size_t>(t)]]) << '\n';
        }
      }
      csv.flush();
      if (!csv) throw Error(*out + ": could not write (disk full?)");
      fmt::print("wrote {} episodes to {}\n", eps.size(), *out);
      return 0;
    }
    // merge
    if (std::filesystem::exists(*out)) throw Error(*out + ": already exists; merge writes a new file");
    const DatasetInfo first = dataset_info(files->front());
    DatasetWriter w(*out, first.env_args);
    for (const auto& f : *files) {
      DatasetInfo i;
      const auto eps = read_dataset(f, &i);
      if (i.env_args != first.env_args) throw Error(f + ": attribute env_args differs from " + files->front() + "'s; not merged");
      for (const auto& ep : eps) w.append(ep);
    }
    fmt::print("merged {} files into {} ({} episodes)\n", files->size(), *out, w.episodes());
    return 0;
  };
}

}  // namespace dd::app
