// gpatlas_bench's command line (parseArgs) on every numeric flag at -1, 0, 1e10 and "x", and at
// values inside the range: a value out of range, not a number, or not an integer where one is
// needed is refused with the flag, the value and the range; one inside it reaches the options.
// The ranges written here are the config parameters' that the flags override (the config
// readers'), or the bench's own bounds.
#include "../tools/bench_options.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace {

using gpatlas_bench::Options;

Options parse(std::vector<std::string> args) {
  args.insert(args.begin(), "gpatlas_bench");
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  Options defaults;
  defaults.config_path = GPATLAS_PIPELINE_CONFIG;
  defaults.simulation_path = GPATLAS_SIMULATION_CONFIG;
  defaults.urdf_path = GPATLAS_VITO_URDF;
  return gpatlas_bench::parseArgs(static_cast<int>(argv.size()), argv.data(), defaults);
}

// The refusal of `flag value` names the flag, the value and says `range`.
void expectRefused(const std::string& flag, const std::string& value, const std::string& range) {
  try {
    parse({flag, value});
    ADD_FAILURE() << flag << " " << value << " was accepted";
  } catch (const std::invalid_argument& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(flag), std::string::npos) << message;
    EXPECT_NE(message.find("'" + value + "'"), std::string::npos) << message;
    EXPECT_NE(message.find(range), std::string::npos) << "'" << message << "' does not say '" << range << "'";
  }
}

struct NumericFlag {
  std::string flag;
  std::string range;                // as the refusal states it
  std::vector<std::string> refused;  // of -1, 0, 1e10, x and a few more
};

TEST(BenchOptions, EveryNumericFlagRefusesValuesOutOfItsRange) {
  const std::vector<NumericFlag> flags = {
      {"--scale", "> 0 and <= 1e+09", {"-1", "0", "1e10", "x", "", "nan", "inf"}},
      {"--size-m", "> 0 and <= 100", {"-1", "0", "1e10", "x", "100.5"}},
      {"--seeds", "from 0 to 1073741824", {"-1", "1e10", "x", "2.5", "2147483648", "1e2"}},
      {"--max-actions", "from 0 to 1000000", {"-1", "-5", "1e10", "x", "1000001", "3.5", "10x"}},
      {"--jobs", "from 1 to 1024", {"-1", "0", "1e10", "x", "1025", "2.0"}},
      {"--curve-every", "from 0 to 1000000", {"-1", "1e10", "x"}},
      {"--curve-resolution-m", ">= 0.0001 and <= 1", {"-1", "0", "1e10", "x", "0.00005"}},
      {"--curve-samples", "from 1 to 1000000", {"-1", "0", "1e10", "x"}},
      {"--variance-every", "from 1 to 1000000", {"-1", "0", "1e10", "x"}},
      {"--reach-directions", "from 1 to 65536", {"-1", "0", "1e10", "x"}},
      {"--shard", "1 <= K <= N, integers, N <= 999999999", {"-1", "0", "1e10", "x", "0/2", "3/2", "1/0", "1/1e10", "x/2", "-1/2"}},
  };
  for (const NumericFlag& f : flags)
    for (const std::string& value : f.refused) expectRefused(f.flag, value, f.range);
  // A seed list is refused at its first bad seed, which the refusal names, and an empty list too.
  try {
    parse({"--seeds", "0,1,x,-1"});
    ADD_FAILURE() << "--seeds 0,1,x,-1 was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--seeds needs an integer from 0 to 1073741824, got 'x'"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(parse({"--seeds", ","}), std::invalid_argument);
}

TEST(BenchOptions, ValuesInsideTheRangeReachTheOptions) {
  const Options defaults = parse({});
  EXPECT_EQ(parse({"--max-actions", "0"}).pipeline.exploration.max_actions, 0);
  EXPECT_EQ(parse({"--max-actions", "1000000"}).pipeline.exploration.max_actions, 1000000);
  EXPECT_EQ(parse({"--max-actions", "7"}).pipeline.exploration.max_actions, 7);
  EXPECT_NE(defaults.pipeline.exploration.max_actions, 7);  // so the 7 above came from the flag
  EXPECT_EQ(parse({"--seeds", "0"}).seeds, std::vector<int>{0});
  EXPECT_EQ(parse({"--seeds", "3,1073741824"}).seeds, (std::vector<int>{3, 1073741824}));
  EXPECT_EQ(parse({"--jobs", "1"}).jobs, 1);
  EXPECT_EQ(parse({"--jobs", "1024"}).jobs, 1024);
  EXPECT_EQ(parse({"--curve-every", "0"}).curve_every, 0);
  EXPECT_EQ(parse({"--curve-samples", "1"}).curve_samples, 1);
  EXPECT_EQ(parse({"--variance-every", "1"}).variance_every, 1);
  EXPECT_EQ(parse({"--reach-directions", "65536"}).reach_directions, 65536);
  EXPECT_DOUBLE_EQ(parse({"--curve-resolution-m", "1e-4"}).curve_resolution_m, 1e-4);
  EXPECT_DOUBLE_EQ(parse({"--curve-resolution-m", "1"}).curve_resolution_m, 1.0);
  EXPECT_DOUBLE_EQ(parse({"--size-m", "100"}).simulation.procedural_size_m, 100.0);
  const Options scaled = parse({"--scale", "0.001", "--object", "procedural:mug"});
  ASSERT_EQ(scaled.objects.size(), 1u);
  EXPECT_DOUBLE_EQ(scaled.objects[0].scale, 0.001);
  const Options two = parse({"--object", "procedural:mug", "--scale", "0.001", "--object", "procedural:box"});
  ASSERT_EQ(two.objects.size(), 2u);
  EXPECT_DOUBLE_EQ(two.objects[0].scale, 1.0);
  EXPECT_DOUBLE_EQ(two.objects[1].scale, 0.001);
  const Options shard = parse({"--shard", "2/3"});
  ASSERT_TRUE(shard.shard.has_value());
  EXPECT_EQ(shard.shard->index, 2);
  EXPECT_EQ(shard.shard->count, 3);
}

TEST(BenchOptions, NeighboursReplaceTheConfigsAndAMalformedOneIsRefused) {
  EXPECT_TRUE(parse({}).simulation.neighbours.empty());  // simulation.yaml has none
  const Options two = parse({"--neighbour", "procedural:box@0,0.22", "--neighbour", "procedural:cylinder@0.02,-0.2,1.5,0.8"});
  ASSERT_EQ(two.simulation.neighbours.size(), 2u);
  EXPECT_EQ(two.simulation.neighbours[1].object, "procedural:cylinder");
  EXPECT_EQ(two.simulation.neighbours[1].offset_xy_m, Eigen::Vector2d(0.02, -0.2));
  EXPECT_EQ(two.simulation.neighbours[1].yaw_rad, 1.5);
  EXPECT_EQ(two.simulation.neighbours[1].scale, 0.8);
  // The flag replaces a list given in the configuration.
  const Options replaced = parse({"--set", "simulation/neighbours=['procedural:sphere@0.2,0']", "--neighbour", "procedural:box@0,0.22"});
  ASSERT_EQ(replaced.simulation.neighbours.size(), 1u);
  EXPECT_EQ(replaced.simulation.neighbours[0].object, "procedural:box");
  EXPECT_EQ(parse({"--set", "simulation/neighbours=['procedural:sphere@0.2,0']"}).simulation.neighbours.size(), 1u);
  for (const char* bad : {"procedural:box", "procedural:box@0", "procedural:box@0,0,0,-1"}) {
    try {
      parse({"--neighbour", bad});
      ADD_FAILURE() << "--neighbour " << bad << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("--neighbour: neighbour '" + std::string(bad) + "' must be OBJECT@DX,DY"),
                std::string::npos)
          << e.what();
    }
  }
}

// A --scale after the last --object scales nothing: refused, instead of a run at the config's
// scale (issue 51's hostile set: a mesh in mm with its --scale after it).
TEST(BenchOptions, ScaleAfterTheLastObjectIsRefused) {
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"--object", "mesh_mm.stl", "--scale", "0.001"},
           {"--scale", "0.001"},
           {"--scale", "0.001", "--object", "a.stl", "--scale", "1"}}) {
    try {
      parse(args);
      ADD_FAILURE() << "accepted " << args.size() << " arguments ending in " << args.back();
    } catch (const std::invalid_argument& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find("--scale " + args.back() + " comes after every --object"), std::string::npos) << message;
      EXPECT_NE(message.find("before the --object"), std::string::npos) << message;
    }
  }
}

// A value left out before the next flag is refused as such, not taken as the value.
TEST(BenchOptions, AFlagWhereTheValueShouldBeIsRefused) {
  for (const std::string& flag : {"--set", "--object", "--config", "--out", "--strategy", "--max-actions"}) {
    try {
      parse({flag, "--no-plot"});
      ADD_FAILURE() << flag << " took --no-plot as its value";
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()), flag + " needs a value, got the flag '--no-plot'");
    }
  }
}

}  // namespace
