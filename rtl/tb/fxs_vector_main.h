// fxs_vector_main.h: the C++ driver and checker of a unit's Verilator
// co-simulation (`rtl-check --sim verilator`): the same records, plusargs,
// checks and report lines as rtl/tb/fxs_vector_tb.vh, without the
// simulator's event scheduler, byte-by-byte $fread or a $random per cycle.
//
// The including file (`<module>_main.cpp`, generated) defines, before this
// text:
//   #include "V<module>_shell.h"      and  typedef V<module>_shell FxsTop;
//   FXS_MUTANT 0 or 1                  (whether the shell has `mutant`)
//   static const int IN_W, OUT_W;      (input and output data bits)
//   struct FxsField { const char* name; int msb, lsb, kind; };
//     kind 0 unsigned, 1 signed (decimal), 2 flags (binary)
//   static const FxsField IN_FIELDS[], OUT_FIELDS[];  and their counts
//   static const int N_IN_FIELDS, N_OUT_FIELDS;
// The shell `<module>_shell` has the testbench's signals as ports: inputs
// clk, rst_n, in_valid, in_data, out_ready (and mutant), outputs in_ready,
// out_valid, out_data; it holds the DUT and, for a top with set-up ports,
// the set-up sequencer of the Verilog testbench.
//
// Records (big endian, as the Verilog testbench reads them):
//   inputs.bin    per vector {zero pad, index[31:0], input data}, IN_RB bytes
//   expected.bin  per vector {zero pad, index[31:0], output data}, OUT_RB
// Plusargs: +N= (required), +FIRST=, +IN=, +EXP=, +SEED=, +STALL=,
//   +TRACE= (FST, when built with --trace-fst), +DUMP=, +MUTANT=.
// With +STALL=0 (the default) no random number is drawn; otherwise two per
// cycle (input valid, output ready) from a generator seeded by +SEED.
//
// One cycle: the outputs settled with clk low are sampled, the checker
// decides the inputs of the next cycle, the clock rises (the DUT samples
// the inputs set in the previous cycle), the new inputs are applied and the
// clock falls. Ends with `P passed, F failed` (exit status 0 only when
// every vector passed).

#include <cerrno>
#include <cinttypes>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <unistd.h>

#include "verilated.h"
#if VM_TRACE
#include "verilated_fst_c.h"
#endif

namespace fxs {

static const int IN_RB = (32 + IN_W + 7) / 8;
static const int OUT_RB = (32 + OUT_W + 7) / 8;
// 32-bit words of a whole record, plus one so that a 64-bit window at any
// bit of it stays inside the array.
static const int IN_WORDS = (8 * IN_RB + 31) / 32 + 1;
static const int OUT_WORDS = (8 * OUT_RB + 31) / 32 + 1;
static const int RING = 1024;

struct Words {
    uint32_t w[(IN_WORDS > OUT_WORDS ? IN_WORDS : OUT_WORDS)];
};

// A big-endian record of `nbytes` into little-endian 32-bit words.
static void from_be(const unsigned char* b, int nbytes, Words& x) {
    std::memset(&x, 0, sizeof x);
    for (int i = 0; i < nbytes; ++i) {
        const int bit = 8 * (nbytes - 1 - i);
        x.w[bit / 32] |= uint32_t(b[i]) << (bit % 32);
    }
}

// Bits [lo + n - 1 : lo] of x, n <= 64.
static uint64_t bits(const Words& x, int lo, int n) {
    const int k = lo / 32, s = lo % 32;
    uint64_t v = (uint64_t(x.w[k]) | (uint64_t(x.w[k + 1]) << 32)) >> s;
    if (s != 0 && k + 2 < int(sizeof x.w / 4)) v |= uint64_t(x.w[k + 2]) << (64 - s);
    return n >= 64 ? v : (v & ((uint64_t(1) << n) - 1));
}

// Whether bits [hi:lo] of x are all zero.
static bool zero_from(const Words& x, int lo, int nbits) {
    for (int b = lo; b < nbits; b += 32) {
        const int n = nbits - b < 32 ? nbits - b : 32;
        if (bits(x, b, n) != 0) return false;
    }
    return true;
}

// x masked to its low `width` bits, in place.
static void mask(Words& x, int width) {
    const int n = int(sizeof x.w / 4);
    for (int k = 0; k < n; ++k) {
        if (32 * k >= width) {
            x.w[k] = 0;
        } else if (32 * (k + 1) > width) {
            x.w[k] &= (uint32_t(1) << (width % 32)) - 1;
        }
    }
}

static bool same(const Words& a, const Words& b) {
    return std::memcmp(&a, &b, sizeof a) == 0;
}

// A port of at most 64 bits (CData, SData, IData, QData) from / to words.
template <class T>
static void put(T& port, const Words& x, int width) {
    port = T(bits(x, 0, width));
}
template <class T>
static void get(const T& port, Words& x, int width) {
    std::memset(&x, 0, sizeof x);
    const uint64_t v = uint64_t(port);
    x.w[0] = uint32_t(v);
    x.w[1] = uint32_t(v >> 32);
    mask(x, width);
}
// A wider port (VlWide).
template <std::size_t N>
static void put(VlWide<N>& port, const Words& x, int width) {
    Words m = x;
    mask(m, width);
    for (std::size_t k = 0; k < N; ++k) port.at(k) = m.w[k];
}
template <std::size_t N>
static void get(const VlWide<N>& port, Words& x, int width) {
    std::memset(&x, 0, sizeof x);
    for (std::size_t k = 0; k < N; ++k) x.w[k] = port.at(k);
    mask(x, width);
}

// The stall generator (splitmix64), drawn only with +STALL > 0.
struct Rng {
    uint64_t s;
    uint32_t next() {
        uint64_t z = (s += 0x9e3779b97f4a7c15ULL);
        z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
        z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
        return uint32_t((z ^ (z >> 31)) >> 32);
    }
    bool pass(int stall) { return stall <= 0 || int(next() % 100) >= stall; }
};

static void field_text(const FxsField* f, int nf, const Words& x, std::string& out) {
    char buf[96];
    for (int i = 0; i < nf; ++i) {
        const int w = f[i].msb - f[i].lsb + 1;
        if (i > 0) out += ", ";
        out += f[i].name;
        out += " = ";
        if (f[i].kind == 2 || w > 64) {
            // Binary, every bit (as Verilog's %b).
            for (int b = f[i].msb; b >= f[i].lsb; --b) out += char('0' + bits(x, b, 1));
            continue;
        }
        const uint64_t v = bits(x, f[i].lsb, w);
        if (f[i].kind == 1 && w < 64 && ((v >> (w - 1)) & 1)) {
            std::snprintf(buf, sizeof buf, "%" PRId64, int64_t(v) - (int64_t(1) << w));
        } else if (f[i].kind == 1) {
            std::snprintf(buf, sizeof buf, "%" PRId64, int64_t(v));
        } else {
            std::snprintf(buf, sizeof buf, "%" PRIu64, v);
        }
        out += buf;
    }
}

static void show(int32_t i, const Words& in, const Words& got, const Words& want) {
    std::string a, b, c;
    field_text(IN_FIELDS, N_IN_FIELDS, in, a);
    field_text(OUT_FIELDS, N_OUT_FIELDS, got, b);
    field_text(OUT_FIELDS, N_OUT_FIELDS, want, c);
    std::printf("mismatch at vector %" PRId32 "\n  in:   %s\n  got:  %s\n  want: %s\n", i,
                a.c_str(), b.c_str(), c.c_str());
}

// Verilog's %h of a `width`-bit value: every digit, lower case.
static void hex(std::FILE* f, const Words& x, int width) {
    for (int d = (width + 3) / 4 - 1; d >= 0; --d) {
        const int n = width - 4 * d < 4 ? width - 4 * d : 4;
        std::fputc("0123456789abcdef"[bits(x, 4 * d, n)], f);
    }
    std::fputc('\n', f);
}

// Records read in bulk: one read of what the file or pipe holds (up to a
// megabyte) at a time, a pointer into the buffer per record.
struct Reader {
    std::FILE* f = nullptr;
    std::vector<unsigned char> buf = std::vector<unsigned char>(1 << 20);
    size_t pos = 0, len = 0;
    bool eof = false;

    // The next `rb` bytes, or null when fewer are left (`got` says how many).
    const unsigned char* next(size_t rb, size_t& got) {
        if (len - pos < rb && !eof) {
            std::memmove(buf.data(), buf.data() + pos, len - pos);
            len -= pos;
            pos = 0;
            while (len < rb && !eof) {
                // read(2), not fread: a pipe gives what it holds, and the
                // other pipe's writer is never left waiting on us.
                const ssize_t r = ::read(fileno(f), buf.data() + len, buf.size() - len);
                if (r < 0 && errno == EINTR) continue;
                if (r <= 0) eof = true;
                else len += size_t(r);
            }
        }
        if (len - pos < rb) {
            got = len - pos;
            return nullptr;
        }
        const unsigned char* p = buf.data() + pos;
        pos += rb;
        got = rb;
        return p;
    }
};

static bool plusarg(int argc, char** argv, const char* name, std::string& v) {
    const size_t n = std::strlen(name);
    for (int i = 1; i < argc; ++i) {
        if (argv[i][0] == '+' && std::strncmp(argv[i] + 1, name, n) == 0
            && argv[i][1 + n] == '=') {
            v = argv[i] + n + 2;
            return true;
        }
    }
    return false;
}

static bool plusarg_int(int argc, char** argv, const char* name, long long& v) {
    std::string s;
    if (!plusarg(argc, argv, name, s)) return false;
    char* end = nullptr;
    const long long x = std::strtoll(s.c_str(), &end, 10);
    if (end == s.c_str() || *end != '\0') return false;
    v = x;
    return true;
}

class Run {
  public:
    Run(int argc, char** argv) : argc_(argc), argv_(argv) {}
    int main();

  private:
    int finish(uint64_t passed, uint64_t failed);
    const unsigned char* read(Reader& r, int rb, const char* what, int64_t k);
    void rise();
    void fall();
    void tick();

    int argc_;
    char** argv_;
    VerilatedContext ctx_;
    FxsTop* top_ = nullptr;
#if VM_TRACE
    VerilatedFstC* fst_ = nullptr;
#endif
    uint64_t time_ = 0;
    long long n_ = 0;
    std::FILE* dump_ = nullptr;
};

void Run::rise() {
    // The rising edge, on the inputs of this cycle; the caller then applies
    // the next cycle's inputs and fall() settles them.
    top_->clk = 1;
    tick();
}

void Run::fall() {
    top_->clk = 0;
    tick();
}

void Run::tick() {
    top_->eval();
#if VM_TRACE
    if (fst_) fst_->dump(time_);
#endif
    ++time_;
}

int Run::finish(uint64_t passed, uint64_t failed) {
    if (dump_) std::fclose(dump_);
    dump_ = nullptr;
    std::printf("%" PRIu64 " passed, %" PRIu64 " failed\n", passed, failed);
#if VM_TRACE
    if (fst_) fst_->close();
#endif
    top_->final();
    std::fflush(stdout);
    return failed == 0 ? 0 : 1;
}

const unsigned char* Run::read(Reader& r, int rb, const char* what, int64_t k) {
    size_t got = 0;
    const unsigned char* p = r.next(size_t(rb), got);
    if (p) return p;
    std::printf("error: %s holds %" PRId64 " of the %lld vectors (record %" PRId64
                " is %zu of %d bytes)\n",
                what, k, n_, k, got, rb);
    return nullptr;
}

int Run::main() {
    ctx_.commandArgs(argc_, argv_);
    long long n = 0, first = 0, stall = 0, seed = 1, mutant = 0;
    if (!plusarg_int(argc_, argv_, "N", n)) {
        std::printf("error: +N=<vector count> is required\n0 passed, 1 failed\n");
        return 1;
    }
    if (n < 1 || n >= (1LL << 31)) {
        std::printf("error: +N=%lld: from 1 to 2^31 - 1 vectors\n0 passed, 1 failed\n", n);
        return 1;
    }
    n_ = n;
    plusarg_int(argc_, argv_, "FIRST", first);
    plusarg_int(argc_, argv_, "STALL", stall);
    plusarg_int(argc_, argv_, "SEED", seed);
    plusarg_int(argc_, argv_, "MUTANT", mutant);
    std::string in_file = "inputs.bin", exp_file = "expected.bin", s;
    plusarg(argc_, argv_, "IN", in_file);
    plusarg(argc_, argv_, "EXP", exp_file);
    std::FILE* fin = std::fopen(in_file.c_str(), "rb");
    std::FILE* fexp = std::fopen(exp_file.c_str(), "rb");
    if (!fin || !fexp) {
        std::printf("error: cannot open the vector files (+IN, +EXP)\n0 passed, %lld failed\n",
                    n);
        return 1;
    }
    Reader rin, rexp;
    rin.f = fin;
    rexp.f = fexp;
    std::string trace;
    const bool tracing = plusarg(argc_, argv_, "TRACE", trace);
#if VM_TRACE
    // Tracing is switched on before the model is made.
    if (tracing) ctx_.traceEverOn(true);
#endif
    top_ = new FxsTop{&ctx_};
    if (plusarg(argc_, argv_, "DUMP", s)) {
        dump_ = std::fopen(s.c_str(), "w");
        if (!dump_) {
            std::printf("error: cannot open +DUMP file\n0 passed, %lld failed\n", n);
            return 1;
        }
    }
    if (tracing) {
#if VM_TRACE
        fst_ = new VerilatedFstC;
        top_->trace(fst_, 99);
        fst_->open(trace.c_str());
#else
        std::printf("error: +TRACE: this simulator was built without tracing\n");
        return finish(0, uint64_t(n));
#endif
    }
    std::printf("vectors streaming: %lld from index %lld\n", n, first);
    std::fflush(stdout);

    const uint32_t first32 = uint32_t(first);
    Rng rng{uint64_t(seed) * 0x2545f4914f6cdd1dULL + 1};
    std::vector<Words> in_ring(RING);
    std::vector<int64_t> in_cycle(RING);
    Words x{}, next_data{}, in_data{}, held_data{}, out{}, want{};
    bool in_valid = false, out_ready = false, held = false, next_loaded = false;
    int64_t in_idx = 0, out_idx = 0, cycle = 0, lat_min = int64_t(1) << 30, lat_max = 0;
    int64_t proto = 0, extra = 0, drain = -1, quiet = 0;
    uint64_t passed = 0, failed = 0;

    top_->clk = 0;
    top_->rst_n = 0;
    top_->in_valid = 0;
    top_->out_ready = 0;
    put(top_->in_data, in_data, IN_W);
#if FXS_MUTANT
    top_->mutant = uint16_t(mutant);
#else
    (void)mutant;
#endif
    top_->eval();
    for (int r = 0; r < 3; ++r) {
        rise();
        fall();
        ++cycle;
    }
    top_->rst_n = 1;
    top_->eval();
    for (;;) {
        // The outputs of this cycle, settled with the clock low.
        const bool in_ready = top_->in_ready;
        const bool out_valid = top_->out_valid;
        // The data matter only with valid (checked, or held under stall).
        if (out_valid) get(top_->out_data, out, OUT_W);
        // Input side: valid stays high until the transfer.
        int64_t nxt = in_idx;
        if (in_valid && in_ready) {
            in_ring[size_t(in_idx % RING)] = in_data;
            in_cycle[size_t(in_idx % RING)] = cycle;
            nxt = in_idx + 1;
            next_loaded = false;
        }
        in_idx = nxt;
        if (nxt - out_idx >= RING) {
            std::printf("error: more than %d vectors in flight\n", RING);
            return finish(passed, uint64_t(n) - passed);
        }
        bool next_valid = in_valid;
        if (!in_valid || in_ready) {
            if (nxt < n && !next_loaded) {
                // Read vector nxt's record once, when it is first needed.
                const unsigned char* rec = read(rin, IN_RB, in_file.c_str(), nxt);
                if (!rec) return finish(passed, uint64_t(n) - passed);
                from_be(rec, IN_RB, x);
                const uint32_t want_idx = first32 + uint32_t(nxt);
                if (bits(x, IN_W, 32) != want_idx || !zero_from(x, IN_W + 32, 8 * IN_RB)) {
                    std::printf("error: %s record %" PRId64 ": index or pad wrong (want index %"
                                PRIu32 ")\n",
                                in_file.c_str(), nxt, want_idx);
                    return finish(passed, uint64_t(n) - passed);
                }
                next_data = x;
                mask(next_data, IN_W);
                next_loaded = true;
            }
            next_valid = nxt < n && rng.pass(int(stall));
            if (next_valid) in_data = next_data;
        }
        // Output handshake: data and valid hold while stalled.
        if (held && (!out_valid || !same(out, held_data))) {
            ++proto;
            if (proto <= 5) {
                std::printf("protocol error at cycle %" PRId64 ": output %" PRId64
                            " %s while valid_o && !ready_i\n",
                            cycle, out_idx, out_valid ? "data changed" : "valid dropped");
            }
        }
        held = out_valid && !out_ready;
        held_data = out;
        ++quiet;
        if (drain >= 0) {
            // After the N-th output: any further output is one too many.
            if (out_valid && out_ready) {
                ++extra;
                if (extra <= 5) {
                    std::printf("error: an output beyond the %lld vectors at cycle %" PRId64
                                "\n",
                                n, cycle);
                }
            }
            if (drain == 0) {
                // Nothing may follow the N-th record in either file.
                size_t left = 0;
                if (rin.next(1, left) != nullptr) {
                    ++extra;
                    std::printf("error: %s holds more than %lld vectors\n", in_file.c_str(), n);
                }
                if (rexp.next(1, left) != nullptr) {
                    ++extra;
                    std::printf("error: %s holds more than %lld vectors\n", exp_file.c_str(),
                                n);
                }
                const uint64_t bad = uint64_t(proto + extra);
                return finish(passed - (bad > passed ? passed : bad), failed + bad);
            }
            --drain;
        } else if (out_valid && out_ready) {
            // Output side: compare every transfer, in order.
            quiet = 0;
            if (dump_) hex(dump_, out, OUT_W);
            const unsigned char* rec = read(rexp, OUT_RB, exp_file.c_str(), out_idx);
            if (!rec) return finish(passed, uint64_t(n) - passed);
            from_be(rec, OUT_RB, want);
            const uint32_t want_idx = first32 + uint32_t(out_idx);
            if (bits(want, OUT_W, 32) != want_idx || !zero_from(want, OUT_W + 32, 8 * OUT_RB)) {
                std::printf("error: %s record %" PRId64 ": index or pad wrong (want index %"
                            PRIu32 ")\n",
                            exp_file.c_str(), out_idx, want_idx);
                return finish(passed, uint64_t(n) - passed);
            }
            mask(want, OUT_W);
            if (same(out, want)) {
                ++passed;
            } else {
                ++failed;
                if (failed <= 5) {
                    show(int32_t(want_idx), in_ring[size_t(out_idx % RING)], out, want);
                }
            }
            const int64_t lat = cycle - in_cycle[size_t(out_idx % RING)];
            if (lat < lat_min) lat_min = lat;
            if (lat > lat_max) lat_max = lat;
            ++out_idx;
            if (out_idx == n) {
                std::printf("latency %" PRId64 " cycles (min), %" PRId64
                            " (max, with stalls)\ncycles %" PRId64 "\n",
                            lat_min, lat_max, cycle);
                // Keep clocking for a while: nothing more may come out.
                drain = 64;
            }
        }
        out_ready = drain >= 0 || rng.pass(int(stall));
        // A stuck design: no output for this many cycles (stalls last a few).
        if (quiet > 100000) {
            std::printf("error: no output for %" PRId64 " cycles, "
                        "%" PRId64 " of %lld vectors out\n",
                        quiet, out_idx, n);
            return finish(passed, uint64_t(n) - passed);
        }
        // The clock rises on this cycle's inputs; then the next cycle's.
        rise();
        in_valid = next_valid;
        top_->in_valid = in_valid;
        put(top_->in_data, in_data, IN_W);
        top_->out_ready = out_ready;
        fall();
        ++cycle;
    }
}

}  // namespace fxs

int main(int argc, char** argv) {
    fxs::Run run(argc, argv);
    return run.main();
}
