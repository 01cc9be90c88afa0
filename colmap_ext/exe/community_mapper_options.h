// The one table of `--CommunityMapper.*` options: each declared once with
// its flag, field, help, and whether it shapes the plan (a later stage or a
// resumed run given another value is refused) or is advanced. The table
// drives the OptionManager registration, project.ini's [CommunityMapper]
// section, the plan's keys and docs/options.md (CommunityMapperOptionsMarkdown,
// testing/testing.h); the defaults are the fields' own
// (CommunityMapperController::Options and the stages' options structs), the
// range checks their Check()s.
#pragma once

#include "colmap_ext/workflow/community_mapper.h"

#include "colmap/controllers/option_manager.h"

#include <set>
#include <string>
#include <utility>
#include <vector>

namespace colmap {

// The controller's options as the command line sets them: the edge weights
// as text, and what the command may do with an earlier run's results.
struct CommunityMapperCommandOptions {
  CommunityMapperController::Options mapper;
  // "unit" or "num_inliers" (ViewGraphEdgeWeightFromString).
  std::string edge_weights = "unit";
  // Replace the results of an earlier run instead of resuming it.
  bool overwrite = false;
};

struct CommunityMapperOption {
  template <typename T>
  CommunityMapperOption(std::string name,
                        T* value,
                        std::string help,
                        bool shapes_plan = false,
                        bool advanced = false,
                        bool saved = true)
      : name(std::move(name)),
        help(std::move(help)),
        shapes_plan(shapes_plan),
        advanced(advanced),
        saved(saved) {
    Bind(value);
  }

  // Calls `visitor` with the field the flag sets (bool*, int*, double* or
  // std::string*).
  template <typename Visitor>
  void Visit(Visitor visitor) const {
    if (bool_value != nullptr) visitor(bool_value);
    if (int_value != nullptr) visitor(int_value);
    if (double_value != nullptr) visitor(double_value);
    if (string_value != nullptr) visitor(string_value);
  }

  // The value as project.ini and docs/options.md write it.
  std::string ValueToText() const;

  // The flag without "--CommunityMapper.".
  std::string name;
  // The field the flag sets: exactly one of these.
  bool* bool_value = nullptr;
  int* int_value = nullptr;
  double* double_value = nullptr;
  std::string* string_value = nullptr;
  std::string help;
  // Recorded in the plan.
  bool shapes_plan = false;
  // An advanced option: after the options users set in -h and the docs.
  bool advanced = false;
  // Written to project.ini (false for overwrite: a saved project must not
  // replace results when it is run again).
  bool saved = true;

 private:
  void Bind(bool* value) { bool_value = value; }
  void Bind(int* value) { int_value = value; }
  void Bind(double* value) { double_value = value; }
  void Bind(std::string* value) { string_value = value; }
};

// Every option, bound to `options`, users' options first.
std::vector<CommunityMapperOption> CommunityMapperOptionTable(
    CommunityMapperCommandOptions* options);

// Registers every option of the table with `option_manager`.
void AddCommunityMapperOptions(CommunityMapperCommandOptions* options,
                               OptionManager* option_manager);

// COLMAP's options as OptionManager writes them to a project file, without
// the command's own, which OptionManager writes too: those outside any
// section whose key is in `own_keys`, and the CommunityMapper section.
std::string ColmapOptionsToIni(const OptionManager& options,
                               const std::set<std::string>& own_keys);

// The [CommunityMapper] section of project.ini with the options' values.
std::string CommunityMapperIniSection(
    const CommunityMapperCommandOptions& options);

// The names of the options that shape the plan.
std::vector<std::string> CommunityMapperPlanKeys();

// The options that shape the plan, as "Section.key=value" lines of a
// project.ini text: every incremental mapper option but its threads, GPU
// index and snapshots, and the plan's CommunityMapper options (the merge's
// own may differ between merges of the same communities).
std::string PlanOptionsFromIni(const std::string& project_ini);

}  // namespace colmap
