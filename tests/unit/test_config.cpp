// Tests of parameters by name (meniscus/config.hpp): keys, types, precedence, presets, the
// artist controls, configuration files and the replay of --stats files.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "meniscus/config.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

using nlohmann::json;

/// The message of the InvalidParameter that params_from_json throws for `object` ("" if none).
std::string refusal(const json& object) {
  try {
    (void)params_from_json(object);
  } catch (const InvalidParameter& e) {
    return e.what();
  }
  ADD_FAILURE() << "accepted " << object.dump();
  return "";
}

void write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

TEST(Config, PresetNamesAndWhatEachSets) {
  EXPECT_EQ(preset_names(), (std::vector<std::string>{"preview", "production", "droplets"}));
  Params production;
  production.voxel_size = 0.3;
  production.r_inner = 0.01;
  production.steps_a = 1;
  apply_preset(production, "production");
  EXPECT_EQ(production, Params{});  // production is exactly the defaults

  Params preview;
  apply_preset(preview, "preview");
  EXPECT_LT(preview.detail, 1.0);
  EXPECT_LT(preview.steps_a + preview.steps_b, Params{}.steps_a + Params{}.steps_b);

  Params droplets;
  apply_preset(droplets, "droplets");
  EXPECT_GT(droplets.r_outer_factor, 1.0);
  EXPECT_EQ(droplets.steps_free, 0);  // nothing leaves the shell
  EXPECT_LT(droplets.steps_a, Params{}.steps_a);

  try {
    apply_preset(droplets, "final");
    ADD_FAILURE() << "unknown preset accepted";
  } catch (const InvalidParameter& e) {
    const std::string m = e.what();
    for (const char* s : {"final", "preview", "production", "droplets"}) EXPECT_NE(m.find(s), std::string::npos) << m;
  }
}

TEST(Config, SmoothnessHalfIsTheDefaultScheduleZeroIsNoneAndItIsMonotone) {
  Params p;
  apply_smoothness(p, 0.5);
  EXPECT_EQ(p, Params{});
  apply_smoothness(p, 0);
  EXPECT_EQ(p.steps_a + p.steps_b + p.steps_free, 0);
  apply_smoothness(p, 1);
  EXPECT_EQ(p.steps_a, 40);
  EXPECT_EQ(p.steps_b, 20);
  EXPECT_EQ(p.steps_free, 6);
  Params previous;
  apply_smoothness(previous, 0);
  for (int i = 1; i <= 100; ++i) {
    Params q;
    apply_smoothness(q, i / 100.0);
    EXPECT_GE(q.steps_a, previous.steps_a) << i;
    EXPECT_GE(q.steps_b, previous.steps_b) << i;
    EXPECT_GE(q.steps_free, previous.steps_free) << i;
    previous = q;
  }
  for (double bad : {-0.1, 1.01, std::nan("")}) EXPECT_THROW(apply_smoothness(p, bad), InvalidParameter) << bad;
}

TEST(Config, DetailSetsTheVoxelSizeThroughResolve) {
  Params p;
  p.spacing = 0.1;
  p.voxel_size = 0.07;
  apply_detail(p, 2);
  EXPECT_EQ(p.voxel_size, 0);  // the detail decides unless a voxel size is given afterwards
  const ParticleSet block = test::lattice_block(4, 4, 4, 0.1f);
  EXPECT_DOUBLE_EQ(resolve_params(block, p).voxel_size, 0.1 / 4);
  apply_detail(p, 0.5);
  EXPECT_DOUBLE_EQ(resolve_params(block, p).voxel_size, 0.1);
  for (double bad : {0.0, -1.0, 9.0}) {
    try {
      apply_detail(p, bad);
      ADD_FAILURE() << "detail " << bad << " accepted";
    } catch (const InvalidParameter& e) {
      EXPECT_NE(std::string(e.what()).find("detail"), std::string::npos) << e.what();
    }
  }
}

TEST(Config, PrecedenceIsPresetThenControlsThenKeysWhateverTheOrder) {
  // Keys listed before the controls still win over them.
  const Params p = params_from_json(json::parse(R"({"steps_b": 7, "voxel_size": 0.03, "smoothness": 1.0,
                                                    "detail": 2, "preset": "preview"})"));
  EXPECT_EQ(p.steps_b, 7);         // explicit key over smoothness
  EXPECT_EQ(p.steps_a, 40);        // smoothness over the preset
  EXPECT_DOUBLE_EQ(p.detail, 2);   // detail over the preset
  EXPECT_DOUBLE_EQ(p.voxel_size, 0.03);  // explicit key over detail

  // On top of a base: only what the object names changes.
  Params base;
  base.spacing = 0.2;
  base.erode = 0.01;
  const Params q = params_from_json(json::parse(R"({"erode": 0.02})"), base);
  EXPECT_DOUBLE_EQ(q.spacing, 0.2);
  EXPECT_DOUBLE_EQ(q.erode, 0.02);
}

TEST(Config, DashesAndUnderscoresAreInterchangeable) {
  const Params p = params_from_json(json::parse(R"({"steps-a": 3, "max-memory-gb": 2.5, "keep-voids": true,
                                                    "relax_b": 0.5, "transfer": "velocity,density"})"));
  EXPECT_EQ(p.steps_a, 3);
  EXPECT_DOUBLE_EQ(p.max_memory_gb, 2.5);
  EXPECT_TRUE(p.keep_voids);
  EXPECT_DOUBLE_EQ(p.relax_b, 0.5);
  EXPECT_EQ(p.transfer, (std::vector<std::string>{"velocity", "density"}));
  EXPECT_EQ(params_from_json(json::parse(R"({"transfer": ["a", "b"]})")).transfer,
            (std::vector<std::string>{"a", "b"}));
  EXPECT_NE(refusal(json::parse(R"({"steps-a": 3, "steps_a": 4})")).find("twice"), std::string::npos);
}

// The clip and decimation keys, in either order (clip_cap needs clip_box, whichever comes first).
TEST(Config, ClipAndDecimateKeys) {
  for (const char* text : {R"({"clip_cap": true, "clip_box": "0,0,0,1,2,3", "decimate": 0.02})",
                           R"({"clip_box": [0, 0, 0, 1, 2, 3], "clip-cap": true, "decimate": 0.02})"}) {
    const Params p = params_from_json(json::parse(text));
    EXPECT_EQ(p.clip_box, (std::vector<double>{0, 0, 0, 1, 2, 3})) << text;
    EXPECT_TRUE(p.clip_cap) << text;
    EXPECT_DOUBLE_EQ(p.decimate, 0.02) << text;
  }
  EXPECT_NE(refusal(json::parse(R"({"clip_cap": true})")).find("clip_box"), std::string::npos);
  EXPECT_NE(refusal(json::parse(R"({"decimate": 2})")).find("decimate"), std::string::npos);
  EXPECT_NE(refusal(json::parse(R"({"clip_box": [1, 0, 0, 0, 1, 1]})")).find("xmin"), std::string::npos);
}

TEST(Config, UnknownKeysAreNamedWithTheClosestKnownKey) {
  const std::string m = refusal(json::parse(R"({"steps_a": 3, "stepsb": 2})"));
  EXPECT_NE(m.find("'stepsb'"), std::string::npos) << m;
  EXPECT_NE(m.find("did you mean 'steps_b'"), std::string::npos) << m;
  const std::string far = refusal(json::parse(R"({"colour_of_the_sky": 1})"));
  EXPECT_NE(far.find("colour_of_the_sky"), std::string::npos) << far;
  EXPECT_EQ(far.find("did you mean"), std::string::npos) << far;
}

TEST(Config, WrongTypesAndRangesNameTheKeyAndTheExpectation) {
  struct Case {
    const char* object;
    std::vector<const char*> expected;
  };
  const std::vector<Case> cases = {
      {R"({"steps_a": "many"})", {"steps_a = \"many\"", "a whole number from 0 to 10000"}},
      {R"({"steps_a": 40.5})", {"steps_a = 40.5", "a whole number"}},
      {R"({"steps_a": 2147483648})", {"steps_a = 2147483648", "from 0 to 10000"}},
      {R"({"steps_a": 100000000000000000000})", {"steps_a = 1e+20", "from 0 to 10000"}},
      {R"({"spacing": "0.1"})", {"spacing = \"0.1\"", "expected a finite number"}},
      {R"({"keep_voids": 1})", {"keep_voids", "true or false"}},
      {R"({"extract": 3})", {"extract = 3", "one of tiles, cubes or tetrahedra"}},
      {R"({"extract": "spheres"})", {"extract", "spheres"}},
      {R"({"transfer": [1, 2]})", {"transfer", "array of attribute names"}},
      {R"({"relax": 2.5})", {"relax = 2.5", "a number from 0 to 1"}},
      {R"({"relax": 1.5, "solver": "jacobi"})", {"relax", "Jacobi"}},
      {R"({"solver": "gauss-seidel"})", {"gauss-seidel", "chebyshev"}},
      {R"({"r-outer": -1})", {"r-outer", "r_outer"}},
      {R"({"smoothness": true})", {"smoothness = true", "a number from 0 to 1"}},
      {R"({"detail": 0})", {"detail"}},
      {R"({"preset": "final"})", {"final", "preview"}},
      {R"({"r_inner": 0.2, "r_outer": 0.1})", {"r_inner"}},
      {R"([1, 2])", {"object"}},
  };
  for (const Case& c : cases) {
    const std::string m = refusal(json::parse(c.object));
    for (const char* s : c.expected) EXPECT_NE(m.find(s), std::string::npos) << c.object << " → " << m;
  }
  EXPECT_EQ(params_from_json(json::parse(R"({"steps_a": 40.0})")).steps_a, 40);  // integral float
}

TEST(Config, MalformedJsonIsAFormatErrorWithTheLine) {
  test::TempDir tmp;
  struct Case {
    std::string text, line;
  };
  const std::vector<Case> cases = {
      {"{\n  \"steps_a\": 3,\n  \"steps_b\": 2,\n}\n", "line 4"},   // trailing comma: the '}' on line 4
      {"{\n  \"steps_a\": 3\n  \"steps_b\": 2\n}\n", "line 3"},     // missing comma
      {"{\n  \"steps_a\": 3,\n  \"steps_b\": ", "line 3"},           // truncated
      {"\n\n\n{\"spacing\": 0.1x}", "line 4"},
  };
  for (const Case& c : cases) {
    const std::string path = tmp.file("config.json");
    write_file(path, c.text);
    try {
      (void)read_config(path);
      ADD_FAILURE() << "accepted " << c.text;
    } catch (const FormatError& e) {
      EXPECT_EQ(e.file(), path);
      EXPECT_EQ(e.location(), c.line) << e.what();
      EXPECT_NE(std::string(e.what()).find("malformed JSON"), std::string::npos) << e.what();
    }
  }
  write_file(tmp.file("array.json"), "[1, 2]");
  EXPECT_THROW((void)read_config(tmp.file("array.json")), FormatError);
  EXPECT_THROW((void)read_config(tmp.file("missing.json")), IoError);
  write_file(tmp.file("typo.json"), R"({"r_iner": 0.1})");
  try {
    (void)read_config(tmp.file("typo.json"));
    ADD_FAILURE() << "accepted r_iner";
  } catch (const InvalidParameter& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("typo.json"), std::string::npos) << m;
    EXPECT_NE(m.find("r_inner"), std::string::npos) << m;
  }
}

TEST(Config, AFileIsOneObjectWithEachKeyOnceAndNumbersADoubleHolds) {
  test::TempDir tmp;
  struct Case {
    std::string text, location, says;
  };
  const std::vector<Case> cases = {
      {"{\n  \"steps_a\": 3,\n  \"steps_a\": 4\n}\n", "line 3", "the key \"steps_a\" is given twice"},
      {"{\"clip_box\": [0, 0, 0, 1, 1, 1], \"steps_b\": 2,\n \"steps_b\": 3}", "line 2", "\"steps_b\" is given twice"},
      {"{\"steps_a\": 3}\n{\"steps_b\": 4}\n", "line 2", "malformed JSON"},  // a second object after the first
      {"{\"steps_a\": 3} trailing words", "line 1", "malformed JSON"},
      {"{\n\"spacing\": 1e400}", "line 2", "the number 1e400 is beyond the range of a double"},
  };
  for (const Case& c : cases) {
    const std::string path = tmp.file("config.json");
    write_file(path, c.text);
    try {
      (void)read_config(path);
      ADD_FAILURE() << "accepted " << c.text;
    } catch (const FormatError& e) {
      EXPECT_EQ(e.location(), c.location) << e.what();
      EXPECT_NE(std::string(e.what()).find(c.says), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find("json.exception"), std::string::npos) << e.what();
    }
  }
  // Nested objects keep their own keys: a --stats file has "parameters" and "stages".
  write_file(tmp.file("nested.json"), R"({"stages": {"read": 1}, "parameters": {"steps_a": 5, "read": 2}})");
  EXPECT_THROW((void)read_config(tmp.file("nested.json")), InvalidParameter);  // "read" is no parameter
  write_file(tmp.file("nested.json"), R"({"stages": {"read": 1}, "parameters": {"steps_a": 5}})");
  EXPECT_EQ(read_config(tmp.file("nested.json")).steps_a, 5);
  // A file that is not a configuration (a wrong path, a device) is refused past 16 MB, not read whole.
  try {
    (void)read_config("/dev/zero");
    ADD_FAILURE() << "read /dev/zero as a configuration";
  } catch (const ResourceError& e) {
    EXPECT_NE(std::string(e.what()).find("16.0 MB a configuration file may hold"), std::string::npos) << e.what();
  }
}

TEST(Config, EveryKeyOfAStatsFileRoundTripsToIdenticalParams) {
  // Every parameter away from its default, so a key that did not round-trip would show.
  ParticleSet particles = test::lattice_block(6, 6, 6, 0.1f, 0.1f, 3);
  Attribute value{"value", 1, false, std::vector<float>(particles.size(), 2.0f)};
  particles.attributes.push_back(value);
  Params in;
  in.spacing = 0.1;
  in.voxel_size = 0.045;
  in.detail = 1.5;
  in.r_outer = 0.11;
  in.r_inner = 0.04;
  in.r_outer_factor = 1.1;
  in.extract = Extractor::cubes;
  in.keep_voids = true;
  in.steps_a = 5;
  in.steps_b = 6;
  in.steps_free = 1;
  in.relax = 0.9;
  in.relax_b = 0.8;
  in.solver = SmoothingSolver::jacobi;
  in.rebuild_b = 2;
  in.erode = 0.001;
  in.transfer = {"value"};
  in.transfer_radius = 0.15;
  in.threads = 1;
  in.max_memory_gb = 3.5;
  in.backend = Backend::cpu;
  in.kernel_radius = 0.2;
  in.smooth_particles = 0.25;
  in.velocity_min_weight = 0.3;
  const Result result = reconstruct(particles, in);
  ASSERT_EQ(result.params, in);  // nothing left to derive

  test::TempDir tmp;
  const std::string stats = stats_to_json(result);
  write_file(tmp.file("stats.json"), stats);
  // A stats file replays everything but the recording machine's resources, which come from the
  // machine (or the options) of the replay.
  Params resources_here;
  resources_here.threads = 3;
  resources_here.max_memory_gb = 7;
  Params expected = result.params;
  expected.threads = 3, expected.max_memory_gb = 7, expected.backend = Backend::automatic;
  EXPECT_EQ(read_config(tmp.file("stats.json"), resources_here), expected);
  expected.threads = 0, expected.max_memory_gb = 0;
  EXPECT_EQ(read_config(tmp.file("stats.json")), expected);

  // The parameters object alone is a configuration too, and each of its keys is known.
  const json parameters = json::parse(stats)["parameters"];
  write_file(tmp.file("config.json"), parameters.dump(2));
  EXPECT_EQ(read_config(tmp.file("config.json")), result.params);
  for (auto it = parameters.begin(); it != parameters.end(); ++it) {
    Params p;
    EXPECT_NO_THROW(set_param(p, it.key(), it.value())) << it.key();
  }
  // A derived run replays with the derived values filled in (the machine's resources left to the
  // replay).
  const Result derived = reconstruct(particles, Params{});
  write_file(tmp.file("derived.json"), stats_to_json(derived));
  Params derived_here = derived.params;
  derived_here.threads = 0, derived_here.max_memory_gb = 0, derived_here.backend = Backend::automatic;
  EXPECT_EQ(read_config(tmp.file("derived.json")), derived_here);
}

}  // namespace
}  // namespace meniscus
