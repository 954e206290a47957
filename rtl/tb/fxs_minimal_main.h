// fxs_minimal_main.h: the minimal Verilator harness `fxshade bench cosim`
// measures the co-simulation driver against (rtl/tb/fxs_vector_main.h): the
// same shell and records, every record read into memory before the clock
// starts, valid and ready held high, every output compared; no index, pad
// or protocol checks, no stalls, no streaming. Prints `P passed, F failed`
// and exits 0 only when every vector passed.
//
// Pasted after the prelude of a generated `<module>_main.cpp` (FxsTop,
// IN_W, OUT_W). Plusargs: +N=, +IN=, +EXP=.

#include <cinttypes>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "verilated.h"

namespace fxs_min {

static const int IN_RB = (32 + IN_W + 7) / 8;
static const int OUT_RB = (32 + OUT_W + 7) / 8;
static const int WORDS = ((IN_W > OUT_W ? IN_W : OUT_W) + 31) / 32 + 1;

// The data bits of a big-endian record as little-endian 32-bit words.
static void data(const unsigned char* rec, int rb, int width, uint32_t* w) {
    std::memset(w, 0, sizeof(uint32_t) * WORDS);
    for (int i = 0; i < rb; ++i) {
        const int bit = 8 * (rb - 1 - i);
        if (bit < width + 32) w[bit / 32] |= uint32_t(rec[i]) << (bit % 32);
    }
    for (int k = 0; k < WORDS; ++k) {
        if (32 * k >= width) w[k] = 0;
        else if (32 * (k + 1) > width) w[k] &= (uint32_t(1) << (width % 32)) - 1;
    }
}

template <class T>
static void put(T& port, const uint32_t* w) {
    port = T(uint64_t(w[0]) | (uint64_t(w[1]) << 32));
}
template <std::size_t N>
static void put(VlWide<N>& port, const uint32_t* w) {
    for (std::size_t k = 0; k < N; ++k) port.at(k) = w[k];
}
template <class T>
static bool equal(const T& port, const uint32_t* w) {
    return uint64_t(port) == (uint64_t(w[0]) | (uint64_t(w[1]) << 32));
}
template <std::size_t N>
static bool equal(const VlWide<N>& port, const uint32_t* w) {
    for (std::size_t k = 0; k < N; ++k) {
        if (port.at(k) != w[k]) return false;
    }
    return true;
}

static std::string arg(int argc, char** argv, const char* name, const char* dflt) {
    const size_t n = std::strlen(name);
    for (int i = 1; i < argc; ++i) {
        if (argv[i][0] == '+' && std::strncmp(argv[i] + 1, name, n) == 0
            && argv[i][1 + n] == '=') {
            return argv[i] + n + 2;
        }
    }
    return dflt;
}

static bool slurp(const std::string& path, std::vector<unsigned char>& b, size_t want) {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) return false;
    b.resize(want);
    const size_t got = std::fread(b.data(), 1, want, f);
    std::fclose(f);
    return got == want;
}

}  // namespace fxs_min

int main(int argc, char** argv) {
    using namespace fxs_min;
    const long long n = std::atoll(arg(argc, argv, "N", "0").c_str());
    std::vector<unsigned char> in, exp;
    if (n < 1 || !slurp(arg(argc, argv, "IN", "inputs.bin"), in, size_t(n) * IN_RB)
        || !slurp(arg(argc, argv, "EXP", "expected.bin"), exp, size_t(n) * OUT_RB)) {
        std::printf("error: +N, +IN or +EXP\n0 passed, 1 failed\n");
        return 1;
    }
    VerilatedContext ctx;
    ctx.commandArgs(argc, argv);
    FxsTop* top = new FxsTop{&ctx};
    uint32_t w[WORDS];
    top->clk = 0;
    top->rst_n = 0;
    top->in_valid = 0;
    top->out_ready = 1;
    top->eval();
    for (int r = 0; r < 3; ++r) {
        top->clk = 1;
        top->eval();
        top->clk = 0;
        top->eval();
    }
    top->rst_n = 1;
    long long sent = 0, got = 0, passed = 0, failed = 0, idle = 0;
    data(&in[0], IN_RB, IN_W, w);
    put(top->in_data, w);
    top->in_valid = 1;
    top->eval();
    while (got < n && idle < 100000) {
        const bool took = top->in_valid && top->in_ready;
        const bool out = top->out_valid;
        if (out) {
            data(&exp[size_t(got) * OUT_RB], OUT_RB, OUT_W, w);
            if (equal(top->out_data, w)) ++passed;
            else ++failed;
            ++got;
            idle = 0;
        } else {
            ++idle;
        }
        top->clk = 1;
        top->eval();
        if (took) {
            ++sent;
            if (sent < n) {
                data(&in[size_t(sent) * IN_RB], IN_RB, IN_W, w);
                put(top->in_data, w);
            } else {
                top->in_valid = 0;
            }
        }
        top->clk = 0;
        top->eval();
    }
    top->final();
    std::printf("%lld passed, %lld failed\n", passed, n - passed);
    delete top;
    return failed == 0 && passed == n ? 0 : 1;
}
