// A minimal test harness: each test is a function registered by name; a failed CHECK prints
// the expression and location and marks the test failed; main() runs one test or all of them.
#pragma once

#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace check {

struct Test {
    const char* name;
    std::function<void()> body;
};
inline std::vector<Test>& registry() {
    static std::vector<Test> tests;
    return tests;
}
inline int& failures() {
    static int n = 0;
    return n;
}
struct Register {
    Register(const char* name, std::function<void()> body) { registry().push_back({name, body}); }
};

inline int run(int argc, char** argv) {
    int failed_tests = 0;
    for (const Test& t : registry()) {
        if (argc > 1 && std::strcmp(argv[1], t.name) != 0) continue;
        const int before = failures();
        try {
            t.body();
        } catch (const std::exception& e) {
            std::printf("  %s: unexpected exception: %s\n", t.name, e.what());
            ++failures();
        }
        const bool ok = failures() == before;
        failed_tests += ok ? 0 : 1;
        std::printf("%s %s\n", ok ? "PASS" : "FAIL", t.name);
    }
    return failed_tests == 0 ? 0 : 1;
}

}  // namespace check

#define TEST_CASE(name)                                        \
    static void name();                                        \
    static const check::Register register_##name(#name, name); \
    static void name()

#define CHECK(expr)                                                                \
    do {                                                                           \
        if (!(expr)) {                                                             \
            std::printf("  %s:%d: CHECK(%s) failed\n", __FILE__, __LINE__, #expr); \
            ++check::failures();                                                   \
        }                                                                          \
    } while (0)

#define CHECK_NEAR(a, b, tol)                                                                                          \
    do {                                                                                                               \
        const double check_a = (a), check_b = (b);                                                                     \
        if (!(std::abs(check_a - check_b) <= (tol))) {                                                                 \
            std::printf("  %s:%d: CHECK_NEAR(%s, %s) failed: %.12g vs %.12g (tol %.3g)\n", __FILE__, __LINE__, #a, #b, \
                        check_a, check_b, double(tol));                                                                \
            ++check::failures();                                                                                       \
        }                                                                                                              \
    } while (0)

#define CHECK_THROWS(exception_type, ...)                                                                     \
    do {                                                                                                      \
        bool check_thrown = false;                                                                            \
        try {                                                                                                 \
            (void)(__VA_ARGS__);                                                                              \
        } catch (const exception_type&) {                                                                     \
            check_thrown = true;                                                                              \
        }                                                                                                     \
        if (!check_thrown) {                                                                                  \
            std::printf("  %s:%d: %s did not throw %s\n", __FILE__, __LINE__, #__VA_ARGS__, #exception_type); \
            ++check::failures();                                                                              \
        }                                                                                                     \
    } while (0)
