// bench/peers: locd against FCL, Bullet and CGAL on one .aabb scene.
//
//   peers [options] SCENE.aabb
//
// The scene is loaded once; locd's exact pair set (1 thread, sorted) is the
// reference. Every peer then runs in a forked child of this process (so its
// peak memory is its own, a crash or a runaway peer cannot take the benchmark
// down, and a peer over its time budget is killed), R times; the medians of
// the stage times are reported. The child compares the pairs of its last run
// with the reference and attributes every difference:
//   missing, touching : the boxes only touch (a face, edge or corner): the
//                       peer treats boxes as open there;
//   missing, overlap  : a real overlap the peer did not report;
//   extra, disjoint   : boxes apart by a gap (margins, quantization);
//   duplicates        : the same pair reported more than once;
//   extra, overlap / ref not overlapping : locd itself is wrong (never expected).
// Output: a table on stdout and, with --csv, one CSV row per peer.
#include "peers.h"

extern "C" {
#include "cli.h"
}

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <poll.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

double peer_now_ms()
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

namespace {

long long proc_status_kb(const char *field);

// ------------------------------------------------------------------ peers

struct peer_desc {
    const char *name;
    peer_fn fn;
    int exact;       // must equal locd's set exactly (closed boxes, no margin)
    int brute_limit; // subject to --brute-max
    const char *what;
    int warms_up;    // its first run includes an untimed warm-up call (locd's cold engine)
};

// locd through its public API, one engine per child: the first call (engine
// buffers growing to size) is reported as cold_ms, the timed calls reuse the
// engine as a caller would frame after frame.
struct locd_state {
    locd_engine *eng = nullptr;
    locd_pairs *pairs = nullptr;
};
locd_state g_locd;

int run_locd(uint32_t threads, const peer_scene &s, peer_pairs &out, peer_times &t, char *err, std::size_t errlen)
{
    locd_stats st;
    if (!g_locd.eng) {
        locd_engine_config cfg;
        locd_engine_config_init(&cfg);
        cfg.threads = threads;
        double t0 = peer_now_ms();
        if (locd_engine_create(&cfg, &g_locd.eng) != LOCD_OK || locd_pairs_create(nullptr, &g_locd.pairs) != LOCD_OK) {
            std::snprintf(err, errlen, "locd: %s", locd_last_error());
            return 1;
        }
        t.prep_ms = peer_now_ms() - t0;
        t0 = peer_now_ms();
        if (locd_engine_find_pairs_f32(g_locd.eng, s.b, s.n, 0, g_locd.pairs) != LOCD_OK) {
            std::snprintf(err, errlen, "locd: %s", locd_last_error());
            return 1;
        }
        t.cold_ms = peer_now_ms() - t0;
    }
    double t0 = peer_now_ms();
    locd_status rc = locd_engine_find_pairs_f32(g_locd.eng, s.b, s.n, 0, g_locd.pairs);
    t.query_ms = peer_now_ms() - t0;
    if (rc != LOCD_OK) {
        std::snprintf(err, errlen, "locd: %s", locd_last_error());
        return 1;
    }
    locd_stats_init(&st);
    locd_engine_get_stats(g_locd.eng, &st);
    t.engine_ms = st.ms_total;
    t.threads = st.threads;
    // locd's peak is reached inside the calls; the copy below is the harness's.
    static bool first = true;
    if (first)
        t.hwm_kb = proc_status_kb("VmHWM");
    first = false;
    const uint32_t *p = locd_pairs_data(g_locd.pairs);
    std::size_t m = locd_pairs_count(g_locd.pairs);
    out.reserve(m);
    for (std::size_t k = 0; k < m; k++) // outside the timed call: the engine's buffer is its result
        out.push_back(peer_pair(p[2 * k], p[2 * k + 1]));
    return 0;
}

int peer_locd_1(const peer_scene &s, peer_pairs &o, peer_times &t, char *e, std::size_t l)
{
    return run_locd(1, s, o, t, e, l);
}

int peer_locd_all(const peer_scene &s, peer_pairs &o, peer_times &t, char *e, std::size_t l)
{
    return run_locd(0, s, o, t, e, l);
}

inline bool overlap(const float *a, const float *b)
{
    return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
}

// The O(n^2) reference, written here independently of locd.
int peer_brute(const peer_scene &s, peer_pairs &out, peer_times &t, char *, std::size_t)
{
    double t0 = peer_now_ms();
    for (std::size_t i = 0; i < s.n; i++)
        for (std::size_t j = i + 1; j < s.n; j++)
            if (overlap(s.b + 6 * i, s.b + 6 * j))
                out.push_back(((std::uint64_t)i << 32) | j);
    t.query_ms = peer_now_ms() - t0;
    return 0;
}

const peer_desc peers_all[] = {
    {"locd_1t", peer_locd_1, 1, 0, "locd, 1 thread (public API, engine reused)", 1},
    {"locd", peer_locd_all, 1, 0, "locd, one thread per core", 1},
    {"fcl_dynamic_aabb_tree", peer_fcl_dynamic_aabb_tree, 0, 0, "FCL 0.7 DynamicAABBTreeCollisionManager"},
    {"fcl_dynamic_aabb_tree_array", peer_fcl_dynamic_aabb_tree_array, 0, 0,
     "FCL 0.7 DynamicAABBTreeCollisionManager_Array"},
    {"fcl_sap", peer_fcl_sap, 0, 0, "FCL 0.7 SaPCollisionManager"},
    {"fcl_ssap", peer_fcl_ssap, 0, 0, "FCL 0.7 SSaPCollisionManager"},
    {"fcl_interval_tree", peer_fcl_interval_tree, 0, 0, "FCL 0.7 IntervalTreeCollisionManager"},
    {"bullet_dbvt", peer_bullet_dbvt, 0, 0, "Bullet btDbvtBroadphase (pairs found as proxies are added)"},
    {"bullet_dbvt_deferred", peer_bullet_dbvt_deferred, 0, 0,
     "Bullet btDbvtBroadphase, m_deferedcollide (pairs found in calculateOverlappingPairs)"},
    {"bullet_axis_sweep", peer_bullet_axis_sweep, 0, 0, "Bullet bt32BitAxisSweep3 (world box fitted to the scene)"},
    {"cgal_closed", peer_cgal_closed, 1, 0, "CGAL box_self_intersection_d, Box_intersection_d::CLOSED"},
    {"cgal_half_open", peer_cgal_half_open, 0, 0,
     "CGAL box_self_intersection_d, Box_intersection_d::HALF_OPEN (touching boxes apart)"},
    {"brute_force", peer_brute, 1, 1, "O(n^2) loop over all pairs (closed test)"},
};

// ------------------------------------------------------------------ results

enum run_status { RUN_OK = 0, RUN_ERROR = 1, RUN_OVER_BUDGET = 2, RUN_CRASHED = 3, RUN_SKIPPED = 4 };

struct run_result {
    int status;
    int reps;
    unsigned threads;
    double prep_ms, setup_ms, query_ms, total_ms, engine_ms, cold_ms;
    std::uint64_t reported, unique, dupes;
    std::uint64_t missing_touching, missing_overlap, extra_disjoint;
    std::uint64_t extra_overlap, ref_false; // locd wrong: never expected
    double max_gap, max_gap_rel;            // largest gap among extra, disjoint pairs (absolute, / box extent)
    long long rss_bytes;                    // peak RSS above the child's RSS at start
    char example[160];
    char err[200];
};

long long proc_status_kb(const char *field)
{
    FILE *f = std::fopen("/proc/self/status", "r");
    char line[256];
    long long v = -1;
    std::size_t len = std::strlen(field);
    if (!f)
        return -1;
    while (std::fgets(line, sizeof line, f))
        if (!std::strncmp(line, field, len) && line[len] == ':') {
            v = std::atoll(line + len + 1);
            break;
        }
    std::fclose(f);
    return v;
}

double median(std::vector<double> v)
{
    if (v.empty())
        return -1.0;
    std::sort(v.begin(), v.end());
    std::size_t k = v.size();
    return k % 2 ? v[k / 2] : 0.5 * (v[k / 2 - 1] + v[k / 2]);
}

bool touching(const float *a, const float *b)
{
    for (int k = 0; k < 3; k++)
        if (a[k] == b[k + 3] || b[k] == a[k + 3])
            return true;
    return false;
}

// Compares a peer's pairs (sorted here) with the sorted reference.
void compare(const peer_scene &s, peer_pairs &got, const peer_pairs &ref, run_result &r)
{
    std::sort(got.begin(), got.end());
    std::size_t before = got.size();
    got.erase(std::unique(got.begin(), got.end()), got.end());
    r.reported = before;
    r.unique = got.size();
    r.dupes = before - got.size();
    std::size_t a = 0, b = 0;
    std::string ex_missing, ex_extra;
    auto name = [](std::uint64_t p) {
        return std::to_string(p >> 32) + "," + std::to_string(p & 0xffffffffu);
    };
    while (a < got.size() || b < ref.size()) {
        if (b == ref.size() || (a < got.size() && got[a] < ref[b])) { // extra
            std::uint64_t p = got[a++];
            const float *x = s.b + 6 * (p >> 32), *y = s.b + 6 * (p & 0xffffffffu);
            if (overlap(x, y)) {
                r.extra_overlap++;
            } else {
                double gap = 0, ext = 0;
                for (int k = 0; k < 3; k++) {
                    gap = std::max(gap, std::max((double)x[k] - y[k + 3], (double)y[k] - x[k + 3]));
                    ext = std::max(ext, std::max((double)x[k + 3] - x[k], (double)y[k + 3] - y[k]));
                }
                r.extra_disjoint++;
                r.max_gap = std::max(r.max_gap, gap);
                if (ext > 0)
                    r.max_gap_rel = std::max(r.max_gap_rel, gap / ext);
            }
            if (ex_extra.empty())
                ex_extra = "extra " + name(p);
        } else if (a == got.size() || ref[b] < got[a]) { // missing
            std::uint64_t p = ref[b++];
            const float *x = s.b + 6 * (p >> 32), *y = s.b + 6 * (p & 0xffffffffu);
            if (!overlap(x, y))
                r.ref_false++;
            else if (touching(x, y))
                r.missing_touching++;
            else
                r.missing_overlap++;
            if (ex_missing.empty())
                ex_missing = "missing " + name(p);
        } else {
            a++;
            b++;
        }
    }
    std::string ex = ex_missing + (ex_missing.empty() || ex_extra.empty() ? "" : "; ") + ex_extra;
    std::snprintf(r.example, sizeof r.example, "%s", ex.c_str());
}

// ------------------------------------------------------------------ children

struct options {
    std::size_t reps = 5;
    double budget_s = 20.0;
    std::size_t brute_max = 20000;
    const char *csv = nullptr;
    const char *scene_name = nullptr;
    std::string only; // comma list; empty = all
    int check_exact = 0;
};

bool selected(const options &o, const char *name)
{
    if (o.only.empty())
        return true;
    std::string list = "," + o.only + ",";
    return list.find(std::string(",") + name + ",") != std::string::npos;
}

void write_all(int fd, const void *data, std::size_t len)
{
    const char *p = static_cast<const char *>(data);
    while (len) {
        ssize_t w = write(fd, p, len);
        if (w < 0 && errno == EINTR)
            continue;
        if (w <= 0)
            _exit(111);
        p += w;
        len -= (std::size_t)w;
    }
}

// In the child: R repetitions (fewer when the budget would be exceeded), then
// the comparison. Sends one byte after the first repetition (the parent's
// hard deadline covers the first repetition only), then the result.
void child_main(int fd, const peer_desc &p, const peer_scene &s, const peer_pairs &ref, const options &o)
{
    run_result r;
    std::memset(&r, 0, sizeof r);
    long long rss0 = proc_status_kb("VmRSS");
    std::vector<double> prep, setup, query, total, engine;
    peer_pairs got;
    double start = peer_now_ms(), cold = -1;
    long long own_hwm = -1;
    unsigned threads = 1;
    for (std::size_t k = 0; k < o.reps; k++) {
        peer_times t;
        double r0 = peer_now_ms();
        got.clear();
        if (p.fn(s, got, t, r.err, sizeof r.err) != 0) {
            r.status = RUN_ERROR;
            break;
        }
        double rep_ms = peer_now_ms() - r0;
        if (t.cold_ms > 0) { // the warm-up call is not a repetition
            rep_ms -= t.cold_ms;
            start += t.cold_ms;
        }
        if (k == 0) {
            char one = 1;
            write_all(fd, &one, 1);
        }
        prep.push_back(t.prep_ms);
        setup.push_back(t.setup_ms);
        query.push_back(t.query_ms);
        total.push_back(t.setup_ms + t.query_ms);
        if (t.engine_ms >= 0)
            engine.push_back(t.engine_ms);
        if (t.cold_ms >= 0)
            cold = t.cold_ms;
        if (t.threads)
            threads = t.threads;
        if (t.hwm_kb >= 0 && own_hwm < 0)
            own_hwm = t.hwm_kb;
        r.reps++;
        if (peer_now_ms() - start + rep_ms > o.budget_s * 1e3)
            break;
    }
    long long hwm = own_hwm >= 0 ? own_hwm : proc_status_kb("VmHWM");
    r.rss_bytes = (rss0 >= 0 && hwm >= 0) ? (hwm - rss0) * 1024 : -1;
    r.threads = threads;
    r.prep_ms = median(prep);
    r.setup_ms = median(setup);
    r.query_ms = median(query);
    r.total_ms = median(total);
    r.engine_ms = median(engine);
    r.cold_ms = cold;
    if (r.status == RUN_OK)
        compare(s, got, ref, r);
    if (r.reps == 0) { // failed before the first byte
        char one = 1;
        write_all(fd, &one, 1);
    }
    write_all(fd, &r, sizeof r);
}

// Reads exactly len bytes before deadline_ms (monotonic); false on timeout/EOF.
bool read_until(int fd, void *buf, std::size_t len, double deadline_ms)
{
    char *p = static_cast<char *>(buf);
    while (len) {
        double left = deadline_ms - peer_now_ms();
        if (left <= 0)
            return false;
        struct pollfd pfd = {fd, POLLIN, 0};
        int pr = poll(&pfd, 1, (int)std::min(left + 1.0, 1e9));
        if (pr < 0 && errno == EINTR)
            continue;
        if (pr <= 0)
            return false;
        ssize_t n = read(fd, p, len);
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0)
            return false;
        p += n;
        len -= (std::size_t)n;
    }
    return true;
}

run_result run_peer(const peer_desc &p, const peer_scene &s, const peer_pairs &ref, const options &o)
{
    run_result r;
    std::memset(&r, 0, sizeof r);
    if (p.brute_limit && s.n > o.brute_max) {
        r.status = RUN_SKIPPED;
        std::snprintf(r.err, sizeof r.err, "skipped: n > --brute-max %zu", o.brute_max);
        return r;
    }
    int fds[2];
    if (pipe(fds) != 0) {
        r.status = RUN_ERROR;
        std::snprintf(r.err, sizeof r.err, "pipe: %s", std::strerror(errno));
        return r;
    }
    std::fflush(stdout);
    std::fflush(stderr);
    pid_t pid = fork();
    if (pid < 0) {
        r.status = RUN_ERROR;
        std::snprintf(r.err, sizeof r.err, "fork: %s", std::strerror(errno));
        close(fds[0]);
        close(fds[1]);
        return r;
    }
    if (pid == 0) {
        close(fds[0]);
        child_main(fds[1], p, s, ref, o);
        _exit(0);
    }
    close(fds[1]);
    char one;
    double start = peer_now_ms();
    // The first repetition must finish within the budget (twice the budget
    // when a warm-up call precedes it); the rest (the child stops repeating
    // before the budget runs out) and the comparison get a second allowance.
    bool ok = read_until(fds[0], &one, 1, start + o.budget_s * 1e3 * (p.warms_up ? 2 : 1)) &&
              read_until(fds[0], &r, sizeof r, peer_now_ms() + o.budget_s * 1e3 + 120e3);
    int ws = 0;
    if (!ok) {
        kill(pid, SIGKILL);
        waitpid(pid, &ws, 0);
        std::memset(&r, 0, sizeof r);
        if (WIFSIGNALED(ws) && WTERMSIG(ws) != SIGKILL) {
            r.status = RUN_CRASHED;
            std::snprintf(r.err, sizeof r.err, "crashed: signal %d (%s)", WTERMSIG(ws), strsignal(WTERMSIG(ws)));
        } else if (WIFEXITED(ws)) {
            r.status = RUN_CRASHED;
            std::snprintf(r.err, sizeof r.err, "child exited with %d before reporting", WEXITSTATUS(ws));
        } else {
            r.status = RUN_OVER_BUDGET;
            std::snprintf(r.err, sizeof r.err, "over budget: first run exceeded %.0f s (killed)", o.budget_s);
        }
    } else {
        waitpid(pid, &ws, 0);
    }
    close(fds[0]);
    return r;
}

// ------------------------------------------------------------------ output

const char *status_name(int s)
{
    switch (s) {
    case RUN_OK: return "ok";
    case RUN_ERROR: return "error";
    case RUN_OVER_BUDGET: return "over budget";
    case RUN_CRASHED: return "crashed";
    default: return "skipped";
    }
}

std::uint64_t differences(const run_result &r)
{
    return r.missing_touching + r.missing_overlap + r.extra_disjoint + r.extra_overlap + r.ref_false + r.dupes;
}

// One line saying what differs and why; "exact" when nothing does.
std::string verdict(const run_result &r)
{
    if (r.status != RUN_OK)
        return r.err;
    if (!differences(r))
        return "exact";
    std::string v;
    char buf[200];
    auto add = [&v](const std::string &s) { v += (v.empty() ? "" : "; ") + s; };
    if (r.missing_touching) {
        std::snprintf(buf, sizeof buf, "missing %llu touching pairs (treated as open)",
                      (unsigned long long)r.missing_touching);
        add(buf);
    }
    if (r.missing_overlap) {
        std::snprintf(buf, sizeof buf, "missing %llu overlapping pairs", (unsigned long long)r.missing_overlap);
        add(buf);
    }
    if (r.extra_disjoint) {
        std::snprintf(buf, sizeof buf, "extra %llu disjoint pairs (gap <= %.3g = %.3g x box; margin/quantization)",
                      (unsigned long long)r.extra_disjoint, r.max_gap, r.max_gap_rel);
        add(buf);
    }
    if (r.dupes) {
        std::snprintf(buf, sizeof buf, "%llu duplicates", (unsigned long long)r.dupes);
        add(buf);
    }
    if (r.extra_overlap || r.ref_false) {
        std::snprintf(buf, sizeof buf, "LOCD WRONG: %llu overlapping pairs locd missed, %llu locd pairs not overlapping",
                      (unsigned long long)r.extra_overlap, (unsigned long long)r.ref_false);
        add(buf);
    }
    if (r.example[0])
        add(std::string("e.g. ") + r.example);
    return v;
}

std::string csv_field(const std::string &s)
{
    std::string q = "\"";
    for (char c : s)
        q += c == '"' ? std::string("\"\"") : std::string(1, c);
    return q + "\"";
}

void machine(char *buf, std::size_t len)
{
    char model[256];
    cli_cpu_model(model, sizeof model);
    std::snprintf(buf, len, "%s, %ld cores", model, sysconf(_SC_NPROCESSORS_ONLN));
}

const char csv_header[] =
    "scene,n,peer,threads,status,reps,prep_ms,setup_ms,query_ms,total_ms,engine_ms,cold_ms,pairs,ref_pairs,"
    "exact,missing_touching,missing_overlap,extra_disjoint,duplicates,locd_wrong,max_gap,peak_rss_bytes,"
    "bytes_per_object,machine,note\n";

void csv_row(FILE *f, const options &o, const char *scene, const peer_scene &s, const peer_desc &p,
             const run_result &r, std::size_t ref_pairs, const char *mach)
{
    bool ok = r.status == RUN_OK;
    std::fprintf(f, "%s,%zu,%s,%u,%s,%d,", csv_field(o.scene_name ? o.scene_name : scene).c_str(), s.n, p.name,
                 ok ? r.threads : 0, status_name(r.status), r.reps);
    if (ok)
        std::fprintf(f, "%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%llu,%zu,%d,%llu,%llu,%llu,%llu,%llu,%.6g,%lld,%.1f,", r.prep_ms,
                     r.setup_ms, r.query_ms, r.total_ms, r.engine_ms, r.cold_ms, (unsigned long long)r.unique,
                     ref_pairs, differences(r) == 0, (unsigned long long)r.missing_touching,
                     (unsigned long long)r.missing_overlap, (unsigned long long)r.extra_disjoint,
                     (unsigned long long)r.dupes, (unsigned long long)(r.extra_overlap + r.ref_false), r.max_gap,
                     r.rss_bytes, s.n ? (double)r.rss_bytes / (double)s.n : 0.0);
    else
        std::fprintf(f, ",,,,,,,%zu,,,,,,,,,,", ref_pairs);
    std::fprintf(f, "%s,%s\n", csv_field(mach).c_str(), csv_field(verdict(r)).c_str());
}

void usage()
{
    std::printf(
        "usage: peers [options] SCENE.aabb\n"
        "Runs locd and its peers (FCL, Bullet, CGAL, brute force) on one float32 scene, each in a\n"
        "forked child, and compares every peer's pairs with locd's exact set.\n"
        "  --peers a,b,...   run only these (see --list)\n"
        "  --reps R          repetitions per peer; medians are reported (default 5)\n"
        "  --budget S        seconds per peer: the first run is killed past S (\"over budget\"), and no\n"
        "                    further run starts that would end past S (default 20)\n"
        "  --brute-max N     largest n for the O(n^2) brute force (default 20000)\n"
        "  --scene-name S    scene label in the CSV (default: the file name)\n"
        "  --csv FILE        append one row per peer (header written when FILE is new)\n"
        "  --check-exact     exit 2 unless every peer that must be exact (locd, cgal_closed, brute_force)\n"
        "                    ran and matched locd's 1-thread set\n"
        "  --csv-header      print the CSV header line\n"
        "  --list            list the peers\n");
}

} // namespace

int main(int argc, char **argv)
{
    options o;
    const char *path = nullptr;
    for (int a = 1; a < argc; a++) {
        std::string s = argv[a];
        bool more = a + 1 < argc;
        std::size_t v;
        if (s == "--help" || s == "-h") {
            usage();
            return 0;
        } else if (s == "--csv-header") {
            std::fputs(csv_header, stdout);
            return 0;
        } else if (s == "--list") {
            for (const peer_desc &p : peers_all)
                std::printf("%-28s %s%s\n", p.name, p.what, p.exact ? " [must be exact]" : "");
            return 0;
        } else if (s == "--peers" && more) {
            o.only = argv[++a];
        } else if (s == "--reps" && more) {
            if (cli_parse_size(argv[++a], &v) || !v)
                cli_die("peers: bad --reps");
            o.reps = v;
        } else if (s == "--budget" && more) {
            o.budget_s = std::atof(argv[++a]);
            if (!(o.budget_s > 0))
                cli_die("peers: bad --budget");
        } else if (s == "--brute-max" && more) {
            if (cli_parse_size(argv[++a], &o.brute_max))
                cli_die("peers: bad --brute-max");
        } else if (s == "--scene-name" && more) {
            o.scene_name = argv[++a];
        } else if (s == "--csv" && more) {
            o.csv = argv[++a];
        } else if (s == "--check-exact") {
            o.check_exact = 1;
        } else if (s[0] == '-') {
            cli_die("peers: unknown option '%s' (see --help)", s.c_str());
        } else if (!path) {
            path = argv[a];
        } else {
            cli_die("peers: unexpected argument '%s'", s.c_str());
        }
    }
    if (!path) {
        usage();
        return 1;
    }
    if (!o.only.empty()) {
        std::string list = o.only + ",";
        for (std::size_t at = 0, c; (c = list.find(',', at)) != std::string::npos; at = c + 1) {
            std::string nm = list.substr(at, c - at);
            bool known = nm.empty();
            for (const peer_desc &p : peers_all)
                known = known || nm == p.name;
            if (!known)
                cli_die("peers: unknown peer '%s' (see --list)", nm.c_str());
        }
    }
    cli_scene sc;
    if (cli_load_scene(path, &sc) != 0)
        return 1;
    if (sc.f64)
        cli_die("peers: float32 .aabb scenes only");
    peer_scene s = {sc.n, sc.f};

    // Reference: locd, 1 thread, sorted. The engine is gone before any fork.
    peer_pairs ref;
    {
        locd_engine_config cfg;
        locd_engine *eng = nullptr;
        locd_pairs *pairs = nullptr;
        locd_engine_config_init(&cfg);
        cfg.threads = 1;
        if (locd_engine_create(&cfg, &eng) != LOCD_OK || locd_pairs_create(nullptr, &pairs) != LOCD_OK ||
            locd_engine_find_pairs_f32(eng, s.b, s.n, LOCD_FIND_SORTED, pairs) != LOCD_OK)
            cli_die("peers: locd failed on %s: %s", path, locd_last_error());
        const uint32_t *p = locd_pairs_data(pairs);
        ref.resize(locd_pairs_count(pairs));
        for (std::size_t k = 0; k < ref.size(); k++)
            ref[k] = ((std::uint64_t)p[2 * k] << 32) | p[2 * k + 1];
        locd_pairs_destroy(pairs);
        locd_engine_destroy(eng);
    }

    char mach[320];
    machine(mach, sizeof mach);
    FILE *csv = nullptr;
    if (o.csv) {
        FILE *probe = std::fopen(o.csv, "r");
        bool fresh = !probe;
        if (probe)
            std::fclose(probe);
        csv = std::fopen(o.csv, "a");
        if (!csv)
            cli_die("peers: cannot write %s: %s", o.csv, std::strerror(errno));
        if (fresh)
            std::fputs(csv_header, csv);
    }
    std::printf("scene %s: n = %zu, locd pairs = %zu; %s; locd %s; median of up to %zu runs, budget %.0f s per peer\n",
                o.scene_name ? o.scene_name : path, s.n, ref.size(), mach, locd_version_string(), o.reps, o.budget_s);
    std::printf("%-28s %4s %3s %10s %10s %10s %10s %10s %9s  %s\n", "peer", "reps", "thr", "prep ms", "setup ms",
                "query ms", "total ms", "locd ms", "B/object", "pairs vs locd");
    int exact_failures = 0;
    for (const peer_desc &p : peers_all) {
        if (!selected(o, p.name))
            continue;
        run_result r = run_peer(p, s, ref, o);
        if (r.status == RUN_OK)
            std::printf("%-28s %4d %3u %10.3f %10.3f %10.3f %10.3f %10s %9.1f  %s\n", p.name, r.reps, r.threads,
                        r.prep_ms, r.setup_ms, r.query_ms, r.total_ms,
                        r.engine_ms >= 0 ? std::to_string(r.engine_ms).substr(0, 9).c_str() : "-",
                        s.n ? (double)r.rss_bytes / (double)s.n : 0.0, verdict(r).c_str());
        else
            std::printf("%-28s %4s %3s %10s %10s %10s %10s %10s %9s  %s\n", p.name, "-", "-", "-", "-", "-", "-", "-",
                        "-", verdict(r).c_str());
        std::fflush(stdout);
        if (csv) {
            csv_row(csv, o, path, s, p, r, ref.size(), mach);
            std::fflush(csv);
        }
        bool must = p.exact && r.status != RUN_SKIPPED;
        if (must && (r.status != RUN_OK || differences(r) != 0)) {
            exact_failures++;
            std::fprintf(stderr, "peers: %s must match locd exactly: %s\n", p.name, verdict(r).c_str());
        }
    }
    if (csv)
        std::fclose(csv);
    cli_free_scene(&sc);
    return o.check_exact && exact_failures ? 2 : 0;
}
