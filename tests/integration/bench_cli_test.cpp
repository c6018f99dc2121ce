// SPDX-License-Identifier: Apache-2.0
// `vfit bench`: the Table-1 study and the resolution sweep write what README promises.
#include <filesystem>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.h"

namespace vfit {
namespace {

TEST(BenchCli, Table1RowsHoldThePapersAndOurMillisecondsPerStage) {
  test::TempDir tmp;
  const auto json = tmp / "table1.json";
  const auto r = test::run_cli({"bench", "table1", "--runs", "1", "--rows", "1", "--json", json.string(), "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(test::read_file(json));
  ASSERT_EQ(j["rows"].size(), 1u);
  const auto& row = j["rows"][0];
  EXPECT_EQ(row["garment"], "Dress");
  EXPECT_EQ(row["vertices"], 5875); // the paper's count, reproduced exactly
  for (const char* stage : {"segmentation", "deformation", "penetration", "total"}) {
    SCOPED_TRACE(stage);
    EXPECT_GT(row[stage]["paper_ms"].get<double>(), 0.0);
    EXPECT_GE(row[stage]["median_ms"].get<double>(), 0.0);
    EXPECT_NEAR(row[stage]["speedup"].get<double>(),
                row[stage]["paper_ms"].get<double>() / row[stage]["median_ms"].get<double>(), 1e-6);
  }
  // The total is the sum of the three columns.
  EXPECT_NEAR(row["total"]["median_ms"].get<double>(),
              row["segmentation"]["median_ms"].get<double>() + row["deformation"]["median_ms"].get<double>() +
                  row["penetration"]["median_ms"].get<double>(),
              1e-9);
  EXPECT_TRUE(j["machine"].contains("cpu_model"));
  EXPECT_NE(r.out.find("Dress"), std::string::npos);
  // The simulation in its own column: a fit with it on, not counted in the total.
  EXPECT_GT(row["simulation"]["ms"].get<double>(), 0.0);
  EXPECT_GT(row["simulation"]["steps"].get<int>(), 0);
  EXPECT_NE(row["simulation"]["outcome"].get<std::string>(), "skipped");
  EXPECT_NE(r.out.find("simulation ms"), std::string::npos);
}

TEST(BenchCli, Table1WithoutSimulationHasNoSimulationColumn) {
  test::TempDir tmp;
  const auto json = tmp / "table1.json";
  const auto r = test::run_cli(
      {"bench", "table1", "--runs", "1", "--rows", "1", "--no-simulation", "--json", json.string(), "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(test::read_file(json));
  ASSERT_EQ(j["rows"].size(), 1u);
  EXPECT_FALSE(j["rows"][0].contains("simulation"));
  EXPECT_TRUE(j["rows"][0].contains("total"));
}

TEST(BenchCli, SweepReportsEachSizeAndTheGrowthExponent) {
  test::TempDir tmp;
  const auto json = tmp / "sweep.json";
  const auto r = test::run_cli({"bench", "sweep", "--garment", "trousers", "--max-vertices", "3200", "--runs", "1",
                                "--json", json.string(), "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(test::read_file(json));
  ASSERT_EQ(j["rows"].size(), 2u); // 1000 and 3200 vertices
  EXPECT_EQ(j["rows"][0]["vertices"], 1000);
  EXPECT_EQ(j["rows"][1]["vertices"], 3200);
  EXPECT_TRUE(j["growth_exponent"]["total"].is_number());
}

TEST(BenchCli, AnUnknownStudyOrOptionExitsTwo) {
  EXPECT_EQ(test::run_cli({"bench", "table2"}).exit_code, 2);
  EXPECT_EQ(test::run_cli({"bench", "table1", "--garment", "tee"}).exit_code, 2);
  EXPECT_EQ(test::run_cli({"bench", "table1", "--runs", "0"}).exit_code, 2);
}

} // namespace
} // namespace vfit
