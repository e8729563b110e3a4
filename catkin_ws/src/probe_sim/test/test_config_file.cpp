// config/pipeline.yaml against the readers of every Config it feeds (probe_sim::readPipeline),
// and probe_sim's config/simulation.yaml against the simulated scene's (probe_sim::readSimulation).
#include "probe_sim/simulation_settings.h"

#include "probe_sim/pipeline_config.h"
#include <gpatlas_core/config/config_readers.h>
#include <gpatlas_core/common/parameters.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <set>

namespace {

// One of the repository's files, read by the readers it feeds.
struct ReadFile {
  std::string error;  // before params, which its constructor fills it for
  std::unique_ptr<gpatlas_core::YamlParameters> params;
  std::unique_ptr<gpatlas_core::ParamReader> reader;

  ReadFile(const std::string& path, const std::function<void(gpatlas_core::ParamReader&)>& read)
      : params(gpatlas_core::YamlParameters::fromFile(path, &error)) {
    if (!params) return;
    reader = std::make_unique<gpatlas_core::ParamReader>(*params);
    read(*reader);
  }
};

ReadFile pipelineFile(probe_sim::PipelineConfig* pipeline) {
  return ReadFile(GPATLAS_PIPELINE_CONFIG, [pipeline](gpatlas_core::ParamReader& r) { probe_sim::readPipeline(r, pipeline); });
}

ReadFile simulationFile(probe_sim::SimulationSettings* simulation) {
  return ReadFile(GPATLAS_SIMULATION_CONFIG,
                  [simulation](gpatlas_core::ParamReader& r) { probe_sim::readSimulation(r, simulation); });
}

// The file sets exactly what its readers read: no key that no Config reads (a typo or a removed
// option), and no parameter that the file leaves to a code default.
void expectSetsExactlyWhatIsRead(const ReadFile& file) {
  ASSERT_TRUE(file.params) << file.error;
  const gpatlas_core::ParamReader& reader = *file.reader;
  EXPECT_TRUE(reader.ok()) << reader.errors();
  EXPECT_TRUE(reader.defaultedNames().empty()) << "not set in the file: " << reader.defaulted();
  const std::set<std::string> read(reader.readNames().begin(), reader.readNames().end());
  for (const std::string& key : file.params->leafNames()) EXPECT_TRUE(read.count(key)) << "no Config reads '" << key << "'";
}

// The code's defaults are the file's values, so that a node started without the file behaves
// as the pipeline does.
void expectTheCodesDefaultsAreTheFilesValues(const ReadFile& file) {
  ASSERT_TRUE(file.params) << file.error;
  const gpatlas_core::ParamReader& reader = *file.reader;
  const gpatlas_core::YamlParameters* params = file.params.get();
  ASSERT_FALSE(reader.defaults().empty());
  std::string error;
  for (const auto& [name, code_default] : reader.defaults()) {
    // Both as YAML, so that numbers compare as numbers and lists element by element.
    const auto in_code = gpatlas_core::YamlParameters::fromString("v: " + code_default, &error);
    ASSERT_TRUE(in_code) << name << ": " << error;
    if (const auto numbers = params->numbers(name)) {
      EXPECT_EQ(*numbers, *in_code->numbers("v")) << name << ": the code's default is " << code_default;
    } else if (const auto texts = params->texts(name)) {
      EXPECT_EQ(*texts, in_code->texts("v").value_or(std::vector<std::string>{})) << name;
    } else if (const auto number = params->number(name); number && in_code->number("v")) {
      EXPECT_DOUBLE_EQ(*number, *in_code->number("v")) << name << ": the code's default is " << code_default;
    } else {
      EXPECT_EQ(params->text(name).value_or("?"), in_code->text("v").value_or("")) << name;
    }
  }
}

// The leaf keys of a YAML file of nested blocks ("key: value" lines, two-space indents), by full
// name, each with whether it has its comment: on its own line, or a comment line just above it.
std::map<std::string, bool> leafKeysWithComments(const std::string& path) {
  std::map<std::string, bool> keys;
  std::ifstream file(path);
  std::vector<std::pair<std::size_t, std::string>> sections;  // indent and name of the open ones
  bool comment_above = false;
  std::string line;
  while (std::getline(file, line)) {
    const std::size_t indent = line.find_first_not_of(' ');
    if (indent == std::string::npos) {
      comment_above = false;
      continue;
    }
    if (line[indent] == '#') {
      comment_above = true;
      continue;
    }
    const std::size_t colon = line.find(':', indent);
    const std::string key = line.substr(indent, colon - indent);
    const std::string rest = colon == std::string::npos ? "" : line.substr(colon + 1);
    const std::size_t hash = rest.find('#');
    const bool has_value = rest.substr(0, hash).find_first_not_of(' ') != std::string::npos;
    while (!sections.empty() && sections.back().first >= indent) sections.pop_back();
    if (has_value) {
      std::string name;
      for (const auto& section : sections) name += section.second + "/";
      keys[name + key] = hash != std::string::npos || comment_above;
    } else {
      sections.emplace_back(indent, key);
    }
    comment_above = false;
  }
  return keys;
}

// The comments are the configuration reference: a key cannot come without its documentation.
void expectEveryKeyHasItsComment(const std::string& path) {
  std::string error;
  const auto params = gpatlas_core::YamlParameters::fromFile(path, &error);
  ASSERT_TRUE(params) << error;
  const std::map<std::string, bool> keys = leafKeysWithComments(path);
  std::vector<std::string> names;
  for (const auto& [name, commented] : keys) {
    names.push_back(name);
    EXPECT_TRUE(commented) << path << ": '" << name << "' has no comment on its line or just above it";
  }
  EXPECT_EQ(names, params->leafNames()) << "the lines of " << path << " read as keys, against the YAML parser";
}

TEST(PipelineYaml, SetsEveryParameterTheReadersReadAndNothingElse) {
  probe_sim::PipelineConfig pipeline;
  expectSetsExactlyWhatIsRead(pipelineFile(&pipeline));
}

TEST(PipelineYaml, TheCodesDefaultsAreTheFilesValues) {
  probe_sim::PipelineConfig pipeline;
  expectTheCodesDefaultsAreTheFilesValues(pipelineFile(&pipeline));
}

TEST(PipelineYaml, EveryKeyHasItsComment) { expectEveryKeyHasItsComment(GPATLAS_PIPELINE_CONFIG); }

TEST(SimulationYaml, EveryKeyHasItsComment) { expectEveryKeyHasItsComment(GPATLAS_SIMULATION_CONFIG); }

TEST(SimulationYaml, SetsEveryParameterTheReaderReadsAndNothingElse) {
  probe_sim::SimulationSettings simulation;
  expectSetsExactlyWhatIsRead(simulationFile(&simulation));
  EXPECT_EQ(probe_sim::validate(simulation), "");
}

TEST(SimulationYaml, TheCodesDefaultsAreTheFilesValues) {
  probe_sim::SimulationSettings simulation;
  expectTheCodesDefaultsAreTheFilesValues(simulationFile(&simulation));
}

// config/paper.yaml, the paper's configuration over the file: every name it sets is a parameter,
// and the result reads cleanly.
TEST(PipelineYaml, ThePapersOverlaySetsOnlyParametersAndSelectsTheGlobalGpis) {
  std::string error;
  const auto base = gpatlas_core::YamlParameters::fromFile(GPATLAS_PIPELINE_CONFIG, &error);
  const auto overlay = gpatlas_core::YamlParameters::fromFile(GPATLAS_PAPER_OVERLAY, &error);
  ASSERT_TRUE(base && overlay) << error;
  const std::vector<std::string> names = base->leafNames();
  for (const std::string& key : overlay->leafNames())
    EXPECT_TRUE(std::find(names.begin(), names.end(), key) != names.end()) << "not a parameter: '" << key << "'";
  ASSERT_TRUE(base->overlay(*overlay, &error)) << error;
  gpatlas_core::ParamReader reader(*base);
  probe_sim::PipelineConfig pipeline;
  probe_sim::readPipeline(reader, &pipeline);
  EXPECT_TRUE(reader.ok()) << reader.errors();
  EXPECT_EQ(pipeline.model.type, "gpis");
  EXPECT_EQ(pipeline.view.max_surface_points, 600);
  // Its offs reach the Configs as absent limits, where the file's are set.
  EXPECT_FALSE(pipeline.exploration.max_position_sd_m.has_value());
  EXPECT_FALSE(pipeline.touch.contact_tangent_noise_sigma.has_value());
  EXPECT_FALSE(pipeline.atlas.evidence.surprise_distance_m.has_value());
  probe_sim::PipelineConfig file_only;
  const auto file = gpatlas_core::YamlParameters::fromFile(GPATLAS_PIPELINE_CONFIG, &error);
  ASSERT_TRUE(file) << error;
  gpatlas_core::ParamReader file_reader(*file);
  probe_sim::readPipeline(file_reader, &file_only);
  EXPECT_EQ(file_only.exploration.max_position_sd_m, std::optional<double>(0.005));
  EXPECT_TRUE(file_only.touch.contact_tangent_noise_sigma.has_value());
  EXPECT_TRUE(file_only.atlas.evidence.surprise_distance_m.has_value());
}

// The file's values reach the Configs (a second, independent parse of the text).
TEST(PipelineYaml, ValuesReachTheConfigs) {
  std::string error;
  const auto params = gpatlas_core::YamlParameters::fromString(
      "seed: 7\nexploration: {v_max: 0.05, max_actions: 12}\nview:\n  free_space: {max_rays: 10}\n"
      "segmentation: {crop_min_m: [0.1, -0.2, 0.0], object_hint_m: [1, 2, 3], voxel_leaf_m: off}\n"
      "gpis: {kernel_params: [2.5]}\n",
      &error);
  ASSERT_TRUE(params) << error;
  gpatlas_core::ParamReader reader(*params);
  probe_sim::PipelineConfig c;
  probe_sim::readPipeline(reader, &c);
  ASSERT_TRUE(reader.ok()) << reader.errors();
  EXPECT_EQ(c.seed, 7u);
  EXPECT_EQ(c.exploration.seed, 7u);
  EXPECT_DOUBLE_EQ(c.exploration.v_max, 0.05);
  EXPECT_EQ(c.exploration.max_actions, 12);
  EXPECT_EQ(c.view.free_space.max_rays, 10);
  EXPECT_EQ(c.segmentation.crop_min_m, gpatlas_core::Vector3(0.1, -0.2, 0.0));
  ASSERT_TRUE(c.segmentation.object_hint_m.has_value());
  EXPECT_EQ(*c.segmentation.object_hint_m, gpatlas_core::Vector3(1, 2, 3));
  EXPECT_FALSE(c.segmentation.voxel_leaf_m.has_value());
  const std::unique_ptr<gpatlas_core::SurfaceModel> gpis = c.model.makers.at(gpatlas_core::GpisModel::kName)();
  const std::vector<double>& initial_params = dynamic_cast<const gpatlas_core::GpisModel&>(*gpis).config().initial_params;
  ASSERT_EQ(initial_params.size(), 1u);
  EXPECT_NEAR(std::exp(initial_params[0]), 2.5, 1e-12);
  // Unset sections keep the Configs' own defaults.
  EXPECT_EQ(c.touch.min_point_spacing_m, gpatlas_core::TouchObservationConfig().min_point_spacing_m);
}

}  // namespace
