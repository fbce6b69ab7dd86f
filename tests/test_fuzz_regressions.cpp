// SPDX-License-Identifier: MIT
// Every input the fuzz harnesses (fuzz/) found a crash, hang, sanitizer report or unexpected exception
// with, and hand-written hostile inputs of the same kinds (sizes beyond the data, indices out of range,
// NaN), kept in tests/data/fuzz/<target>/, fed to its reader the way the harness feeds it: each must
// load or fail with a clean spacebvh::Error. Under the sanitizer build (scripts/test-sanitizers.sh)
// this also checks that no memory error or undefined behaviour remains.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz_targets.hpp"
#include "spacebvh/error.hpp"

namespace {

namespace fs = std::filesystem;

std::vector<uint8_t> file_bytes(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

class FuzzRegression : public ::testing::TestWithParam<std::string> {};

TEST_P(FuzzRegression, EveryKeptInputLoadsOrFailsCleanly) {
    const fs::path dir = fs::path(SPACEBVH_TEST_DATA_DIR) / "fuzz" / GetParam();
    if (!fs::is_directory(dir)) GTEST_SKIP() << "no regression inputs for " << GetParam();
    size_t count = 0;
    for (const auto& entry : fs::directory_iterator(dir)) {
        if (!entry.is_regular_file()) continue;
        ++count;
        const std::vector<uint8_t> bytes = file_bytes(entry.path());
        try {
            spacebvh::fuzz::feed(GetParam(), bytes);
        } catch (const spacebvh::Error& e) {
            // A clean rejection names what is wrong; an empty message would help nobody.
            EXPECT_STRNE(e.what(), "") << entry.path();
        } catch (const std::exception& e) {
            ADD_FAILURE() << entry.path() << ": not a spacebvh::Error: " << e.what();
        }
    }
    EXPECT_GT(count, 0u) << dir;
}

INSTANTIATE_TEST_SUITE_P(Targets, FuzzRegression, ::testing::ValuesIn(spacebvh::fuzz::target_names()),
                         [](const auto& info) { return info.param; });

// The feeding itself works: a well-formed input of each text target loads.
TEST(FuzzTargets, WellFormedInputsLoad) {
    const std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    EXPECT_NO_THROW(spacebvh::fuzz::feed("obj", {reinterpret_cast<const uint8_t*>(obj.data()), obj.size()}));
    const std::string row = "spatial@leaf=4;budget=1.5";
    EXPECT_NO_THROW(spacebvh::fuzz::feed("builder_spec", {reinterpret_cast<const uint8_t*>(row.data()), row.size()}));
    const std::string bad_row = "spatial@leaf=-1";
    EXPECT_THROW(
        spacebvh::fuzz::feed("builder_spec", {reinterpret_cast<const uint8_t*>(bad_row.data()), bad_row.size()}),
        spacebvh::Error);
}

}  // namespace
