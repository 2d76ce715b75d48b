// dw_viewer's command line: valid forms parse to what they say; every mistake is a dw::Error that
// names the offending argument (never a silently different demo).
#include "viewer/viewer_options.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace {

dw_viewer::ViewerOptions parse(std::vector<std::string> args) {
  std::vector<const char*> argv{"dw_viewer"};
  for (const auto& a : args) argv.push_back(a.c_str());
  return dw_viewer::parseViewerOptions(static_cast<int>(argv.size()), argv.data());
}

std::string errorOf(std::vector<std::string> args) {
  try {
    parse(std::move(args));
  } catch (const dw::Error& e) {
    return e.what();
  }
  return "";
}

TEST(ViewerOptions, IcpDefaultsAreStockPcl) {
  const auto o = parse({"src.pcd", "tgt.ply"});
  EXPECT_EQ(o.mode, dw_viewer::Mode::Icp);
  EXPECT_EQ(o.source, "src.pcd");
  EXPECT_EQ(o.target, "tgt.ply");
  EXPECT_EQ(o.transformation_epsilon, 0.0);
  EXPECT_GT(o.max_correspondence_distance, 1e150);
  EXPECT_EQ(o.start, dw::StartStrategy::PnnOptimized);
  EXPECT_TRUE(o.screenshot.empty());
  EXPECT_EQ(o.iterations, -1);
}

TEST(ViewerOptions, EveryOptionParses) {
  const auto o = parse({"a.ply",
                        "b.ply",
                        "--max-iterations",
                        "7",
                        "--max-distance",
                        "0.05",
                        "--transformation-epsilon",
                        "1e-8",
                        "--fitness-epsilon",
                        "1e-6",
                        "--start",
                        "kd-ann",
                        "--builder",
                        "qhull",
                        "--threads",
                        "2",
                        "--perturb",
                        "0.1,0,-0.2,5,0,-10",
                        "--screenshot",
                        "out.png",
                        "--iterations",
                        "3",
                        "--size",
                        "800x600",
                        "--pick",
                        "12",
                        "--walk",
                        "34",
                        "--focus",
                        "--graph",
                        "--graph-limit",
                        "1000",
                        "--max-lines",
                        "50",
                        "--no-correspondences",
                        "--walk-scale",
                        "5",
                        "--point-size",
                        "3",
                        "--keys",
                        "n,space,z,m,t,k"});
  EXPECT_EQ(o.max_iterations, 7);
  EXPECT_DOUBLE_EQ(o.max_correspondence_distance, 0.05);
  EXPECT_DOUBLE_EQ(o.transformation_epsilon, 1e-8);
  EXPECT_DOUBLE_EQ(o.euclidean_fitness_epsilon, 1e-6);
  EXPECT_EQ(o.start, dw::StartStrategy::KdAnn);
  EXPECT_EQ(o.builder, dw::BuilderType::Qhull);
  EXPECT_EQ(o.threads, 2u);
  EXPECT_DOUBLE_EQ(o.perturb[2], -0.2);
  EXPECT_DOUBLE_EQ(o.perturb[5], -10);
  EXPECT_EQ(o.screenshot, "out.png");
  EXPECT_EQ(o.iterations, 3);
  EXPECT_EQ(o.width, 800);
  EXPECT_EQ(o.height, 600);
  EXPECT_EQ(o.pick_target, 12);
  EXPECT_EQ(o.walk_source, 34);
  EXPECT_TRUE(o.focus);
  EXPECT_TRUE(o.show_graph);
  EXPECT_EQ(o.graph_limit, 1000u);
  EXPECT_EQ(o.max_lines, 50u);
  EXPECT_FALSE(o.show_correspondences);
  EXPECT_EQ(o.walk_scale, 5);
  EXPECT_DOUBLE_EQ(o.point_size, 3);
  EXPECT_EQ(o.keys, (std::vector<std::string>{"n", "space", "z", "m", "t", "k"}));
}

TEST(ViewerOptions, TinMode) {
  const auto o = parse({"--tin", "mesh.ply", "--screenshot", "t.png"});
  EXPECT_EQ(o.mode, dw_viewer::Mode::Tin);
  EXPECT_EQ(o.tin, "mesh.ply");
  EXPECT_NE(errorOf({"--tin", "mesh.ply", "extra.ply"}).find("--tin takes one file"), std::string::npos);
}

TEST(ViewerOptions, HelpNeedsNothingElse) {
  EXPECT_TRUE(parse({"--help"}).help);
  EXPECT_TRUE(parse({"a.ply", "-h"}).help) << "no SOURCE/TARGET check when only help is wanted";
}

TEST(ViewerOptions, MistakesAreNamed) {
  EXPECT_NE(errorOf({"a.ply"}).find("expected SOURCE and TARGET"), std::string::npos);
  EXPECT_NE(errorOf({"a.ply", "b.ply", "c.ply"}).find("got 3"), std::string::npos);
  EXPECT_NE(errorOf({"a.ply", "b.ply", "--frobnicate"}).find("unknown option '--frobnicate'"),
            std::string::npos);
  EXPECT_NE(errorOf({"a.ply", "b.ply", "--max-iterations"}).find("needs a value"), std::string::npos);
  EXPECT_NE(errorOf({"a.ply", "b.ply", "--max-iterations", "0"}).find("--max-iterations"), std::string::npos);
  EXPECT_NE(errorOf({"a.ply", "b.ply", "--max-iterations", "5x"}).find("'5x'"), std::string::npos);
  EXPECT_NE(errorOf({"a.ply", "b.ply", "--max-distance", "nan"}).find("finite number"), std::string::npos);
  EXPECT_NE(errorOf({"a.ply", "b.ply", "--max-distance", "-1"}).find("> 0"), std::string::npos);
  EXPECT_NE(errorOf({"a.ply", "b.ply", "--start", "nowhere"}), "");
  EXPECT_NE(errorOf({"a.ply", "b.ply", "--builder", "cgal"}).find("--builder"), std::string::npos);
  EXPECT_NE(errorOf({"a.ply", "b.ply", "--size", "800"}).find("WxH"), std::string::npos);
  EXPECT_NE(errorOf({"a.ply", "b.ply", "--size", "10x600"}).find("--size"), std::string::npos);
  EXPECT_NE(errorOf({"a.ply", "b.ply", "--perturb", "1,2,3"}).find("6 numbers"), std::string::npos);
  EXPECT_NE(errorOf({"a.ply", "b.ply", "--perturb", "1,2,3,4,5,x"}).find("'x'"), std::string::npos);
  EXPECT_NE(errorOf({"a.ply", "b.ply", "--pick", "-3"}).find("--pick"), std::string::npos);
  EXPECT_NE(errorOf({"a.ply", "b.ply", "--focus"}).find("--focus needs"), std::string::npos);
  EXPECT_NE(errorOf({"a.ply", "b.ply", "--iterations", "2"}).find("--screenshot only"), std::string::npos);
  EXPECT_NE(errorOf({"a.ply", "b.ply", "--screenshot", ""}).find("file name"), std::string::npos);
  EXPECT_NE(errorOf({"a.ply", "b.ply", "--point-size", "0"}).find("--point-size"), std::string::npos);
  EXPECT_NE(errorOf({"a.ply", "b.ply", "--keys", "n"}).find("--screenshot only"), std::string::npos);
  EXPECT_NE(errorOf({"a.ply", "b.ply", "--screenshot", "o.png", "--keys", "n,q"}).find("'q'"),
            std::string::npos);
  EXPECT_NE(errorOf({"--tin", "m.ply", "--screenshot", "o.png", "--keys", "n"}).find("--tin"),
            std::string::npos);
}

}  // namespace
