// SPDX-License-Identifier: MIT
// The fixture of the command-line tests: runs the `spacebvh` tool (apps/spacebvh) as a separate
// process in a fresh temporary directory per test, with helpers for the files it writes and for
// checking clean failures (exit code 1 or 2 with a message naming the problem, never a crash).
#pragma once

#include <gtest/gtest.h>

#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace spacebvh::testing_support {

namespace fs = std::filesystem;

struct CliResult {
    int exit_code = -1;  // 128 + N when killed by signal N
    std::string output;  // stdout and stderr together
    bool crashed() const { return exit_code >= 128 || exit_code < 0; }
};

// A fresh directory per test, the working directory of every command; removed afterwards.
class Cli : public ::testing::Test {
protected:
    void SetUp() override {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir_ = fs::temp_directory_path() /
               ("spacebvh_cli_" + std::to_string(getpid()) + "_" + info->test_suite_name() + "_" + info->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }

    // Runs `spacebvh ARGS` in the test directory, capturing stdout and stderr.
    CliResult run(const std::string& args) const {
        const std::string command =
            "cd '" + dir_.string() + "' && '" + std::string(SPACEBVH_CLI_PATH) + "' " + args + " 2>&1";
        CliResult result;
        FILE* pipe = popen(command.c_str(), "r");
        if (!pipe) return result;
        std::array<char, 4096> buffer;
        size_t n;
        while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) result.output.append(buffer.data(), n);
        const int status = pclose(pipe);
        if (WIFEXITED(status))
            result.exit_code = WEXITSTATUS(status);
        else if (WIFSIGNALED(status))
            result.exit_code = 128 + WTERMSIG(status);
        return result;
    }

    // Runs `spacebvh ARGS` in the test directory and sends it SIGINT (Ctrl-C) as soon as its output
    // contains `cue`; gives up (SIGKILL, exit code -1) after `limit_seconds`.
    CliResult run_and_interrupt(const std::vector<std::string>& args, const std::string& cue, int limit_seconds) const {
        std::vector<std::string> words = {SPACEBVH_CLI_PATH};
        words.insert(words.end(), args.begin(), args.end());
        std::vector<char*> argv;
        for (std::string& word : words) argv.push_back(word.data());
        argv.push_back(nullptr);
        const std::string directory = dir_.string();
        int fds[2];
        CliResult result;
        if (pipe(fds) != 0) return result;
        const pid_t pid = fork();
        if (pid == 0) {  // only async-signal-safe calls until exec
            dup2(fds[1], STDOUT_FILENO);
            dup2(fds[1], STDERR_FILENO);
            close(fds[0]);
            close(fds[1]);
            if (chdir(directory.c_str()) == 0) execv(argv[0], argv.data());
            _exit(127);
        }
        close(fds[1]);
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(limit_seconds);
        bool interrupted = false, killed = false;
        char buffer[4096];
        for (;;) {
            pollfd readable{fds[0], POLLIN, 0};
            if (poll(&readable, 1, 100) > 0) {
                const ssize_t n = ::read(fds[0], buffer, sizeof buffer);
                if (n <= 0) break;
                result.output.append(buffer, size_t(n));
            }
            if (!interrupted && result.output.find(cue) != std::string::npos) {
                kill(pid, SIGINT);
                interrupted = true;
            }
            if (!killed && std::chrono::steady_clock::now() > deadline) {
                kill(pid, SIGKILL);
                killed = true;
            }
        }
        close(fds[0]);
        int status = 0;
        waitpid(pid, &status, 0);
        if (killed) return result;
        if (WIFEXITED(status))
            result.exit_code = WEXITSTATUS(status);
        else if (WIFSIGNALED(status))
            result.exit_code = 128 + WTERMSIG(status);
        return result;
    }

    std::string path(const std::string& name) const { return (dir_ / name).string(); }

    void write(const std::string& name, const std::string& bytes) const {
        std::ofstream(dir_ / name, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
    }

    std::string read(const std::string& name) const {
        std::ifstream in(dir_ / name, std::ios::binary);
        return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    }

    nlohmann::json read_json(const std::string& name) const { return nlohmann::json::parse(read(name)); }

    // Runs `spacebvh compare ARGS --json c.json` and reads its first scene's rows into `rows`. Fails
    // fatally unless the command succeeds with `expected_rows` rows: call it under
    // ASSERT_NO_FATAL_FAILURE (a fatal failure in a helper only ends the helper).
    void compare_rows(const std::string& args, size_t expected_rows, nlohmann::json& rows) const {
        const CliResult r = run("compare " + args + " --json c.json");
        ASSERT_EQ(r.exit_code, 0) << r.output;
        rows = read_json("c.json")["scenes"][0]["rows"];
        ASSERT_EQ(rows.size(), expected_rows) << rows.dump();
    }

    // A failing command: exit code 1 or 2 (not 0, not a crash), and the output names the problem.
    void expect_clean_failure(const std::string& args, const std::vector<std::string>& mentions) const {
        SCOPED_TRACE("spacebvh " + args);
        const CliResult r = run(args);
        EXPECT_TRUE(r.exit_code == 1 || r.exit_code == 2) << "exit code " << r.exit_code << ", output:\n" << r.output;
        EXPECT_FALSE(r.crashed()) << r.output;
        EXPECT_FALSE(r.output.empty());
        for (const std::string& word : mentions)
            EXPECT_NE(r.output.find(word), std::string::npos) << "no '" << word << "' in:\n" << r.output;
        EXPECT_EQ(r.output.find("internal error"), std::string::npos) << r.output;
    }

    fs::path dir_;
};

inline bool has_png_signature(const std::string& bytes) {
    static const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
    return bytes.size() > 33 &&
           std::equal(signature, signature + 8, reinterpret_cast<const unsigned char*>(bytes.data()));
}

}  // namespace spacebvh::testing_support
