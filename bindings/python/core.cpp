// locd._core: the pybind11 extension behind `import locd`.
//
// Thin on purpose: it turns numpy arrays into (pointer, n) for the public C
// API, releases the GIL around every C call that may take time, copies the
// pairs into a fresh (m, 2) uint32 array, and turns status codes into the
// Python exceptions defined in locd/_errors.py. Policy (defaults, argument
// checking of Python-level options, concurrent.futures semantics) lives in
// locd/__init__.py.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "locd/locd.h"
#include "locd/service.h"

namespace py = pybind11;

// The exception for a failed locd call, from the one status-to-class mapping
// of locd._errors (shared with scene.cpp, which declares it too).
[[noreturn]] void locd_py_raise(locd_status status, const std::string &detail, long long index)
{
    py::object exc = py::module_::import("locd._errors")
                         .attr("from_status")(status, locd_status_string(status), detail, index);
    PyErr_SetObject(reinterpret_cast<PyObject *>(Py_TYPE(exc.ptr())), exc.ptr());
    throw py::error_already_set();
}

namespace {

// Raises the Python exception for a failed call. Reads the thread-local detail
// first: nothing else may call into locd on this thread before that.
[[noreturn]] void raise_status(locd_status status)
{
    locd_py_raise(status, locd_last_error(), static_cast<long long>(locd_last_error_index()));
}

// Using a closed engine: locd.ClosedError (a ValueError, like I/O on a closed file).
[[noreturn]] void raise_closed()
{
    py::object exc = py::module_::import("locd._errors")
                         .attr("ClosedError")(static_cast<int>(LOCD_ERR_INVALID_HANDLE), "the engine is closed");
    PyErr_SetObject(reinterpret_cast<PyObject *>(Py_TYPE(exc.ptr())), exc.ptr());
    throw py::error_already_set();
}

// A validated (n, 6) float32 or float64 array the C side can read in place.
struct Boxes {
    py::array array; // the caller's array when possible, else a converted copy
    const void *data = nullptr;
    size_t n = 0;
    bool f64 = false;
};

// float32 and float64 arrays that C can read in place (native-endian,
// aligned, C-contiguous, shape (n, 6)) take the fast path with no Python
// call; everything else (lists, integer arrays, other layouts, bad input)
// goes through locd._arrays.boxes, the one set of conversion rules the cffi
// module uses too.
Boxes view_boxes(py::handle obj)
{
    Boxes b;
    const int need = py::array::c_style | py::detail::npy_api::NPY_ARRAY_ALIGNED_;
    bool fast = false;
    if (py::isinstance<py::array>(obj)) {
        b.array = py::reinterpret_borrow<py::array>(obj);
        py::dtype dt = b.array.dtype();
        fast = (dt.equal(py::dtype::of<float>()) || dt.equal(py::dtype::of<double>())) && b.array.ndim() == 2 &&
               b.array.shape(1) == 6 && (b.array.flags() & need) == need;
    }
    if (!fast)
        b.array = py::module_::import("locd._arrays").attr("boxes")(obj);
    b.f64 = b.array.dtype().itemsize() == 8;
    b.data = b.array.data();
    b.n = static_cast<size_t>(b.array.shape(0));
    return b;
}

// The pairs as a fresh (m, 2) array: uint32 as the library stores them, or
// int64 (wide) so that subtracting columns cannot wrap.
py::array pairs_to_array(const locd_pairs *pairs, bool wide)
{
    size_t m = locd_pairs_count(pairs);
    const uint32_t *src = locd_pairs_data(pairs);
    std::vector<py::ssize_t> shape{static_cast<py::ssize_t>(m), 2};
    if (!wide) {
        py::array_t<uint32_t> out(shape);
        uint32_t *dst = out.mutable_data();
        if (m) {
            py::gil_scoped_release nogil;
            std::memcpy(dst, src, m * 2 * sizeof(uint32_t));
        }
        return std::move(out);
    }
    py::array_t<int64_t> out(shape);
    int64_t *dst = out.mutable_data();
    {
        py::gil_scoped_release nogil;
        for (size_t k = 0; k < 2 * m; k++)
            dst[k] = src[k];
    }
    return std::move(out);
}

py::dict stats_to_dict(const locd_stats &s)
{
    py::dict d;
    d["threads"] = s.threads;
    d["objects"] = s.objects;
    d["entries"] = s.entries;
    d["candidates"] = s.candidates;
    d["exact_tests"] = s.exact_tests;
    d["pairs"] = s.pairs;
    d["depth"] = s.depth;
    d["ms_total"] = s.ms_total;
    d["ms_bounds"] = s.ms_bounds;
    d["ms_encode"] = s.ms_encode;
    d["ms_sort"] = s.ms_sort;
    d["ms_merge"] = s.ms_merge;
    d["ms_sweep"] = s.ms_sweep;
    d["ms_order"] = s.ms_order;
    d["ms_transfer"] = s.ms_transfer;
    return d;
}

// Owns a locd_pairs buffer; frees it on scope exit.
struct PairsBuffer {
    locd_pairs *p = nullptr;
    PairsBuffer()
    {
        locd_status st = locd_pairs_create(nullptr, &p);
        if (st != LOCD_OK)
            raise_status(st);
    }
    ~PairsBuffer() { locd_pairs_destroy(p); }
    PairsBuffer(const PairsBuffer &) = delete;
    PairsBuffer &operator=(const PairsBuffer &) = delete;
};

class Job;

// One locd_engine plus a reusable pairs buffer. The mutex serializes Python
// threads sharing one Engine; it is only ever taken with the GIL released,
// so a thread waiting for it never blocks the interpreter.
class Engine {
public:
    Engine(int32_t level, uint32_t threads, uint32_t max_depth, int32_t cell_bias, bool cubes,
           py::object service, py::object secret, py::object worker_path, int64_t service_timeout_ms = 0)
    {
        locd_engine_config cfg;
        locd_engine_config_init(&cfg);
        cfg.service_timeout_ms = service_timeout_ms;
        cfg.level = level;
        cfg.threads = threads;
        cfg.max_depth = max_depth;
        cfg.cell_bias = cell_bias;
        cfg.flags = cubes ? LOCD_CONFIG_CUBES : 0u;
        std::string service_s, secret_s, worker_s;
        if (!service.is_none()) {
            service_s = service.cast<std::string>();
            cfg.service_address = service_s.c_str();
        }
        if (!secret.is_none()) {
            secret_s = secret.cast<std::string>();
            cfg.service_secret = secret_s.c_str();
        }
        if (!worker_path.is_none()) {
            worker_s = worker_path.cast<std::string>();
            cfg.worker_path = worker_s.c_str();
        }
        locd_status st;
        {
            // Starting workers or connecting to a service can take a while.
            py::gil_scoped_release nogil;
            st = locd_engine_create(&cfg, &engine_);
        }
        if (st != LOCD_OK)
            raise_status(st);
    }

    ~Engine() { close(); }

    void close()
    {
        // Without the GIL: stopping workers may wait for them.
        py::gil_scoped_release nogil;
        std::lock_guard<std::mutex> lock(mutex_);
        if (!engine_)
            return;
        // A released job of levels 1 and 2 may still run inside the engine:
        // destroy waits for that call and the job's thread (lib/engine/).
        locd_engine_destroy(engine_);
        engine_ = nullptr;
    }

    bool closed() const { return engine_ == nullptr; }
    int32_t level() const { return engine_ ? locd_engine_level(engine_) : 0; }
    uint32_t threads() const { return engine_ ? locd_engine_threads(engine_) : 0; }

    py::array find_pairs(py::handle boxes_obj, bool sort, bool wide)
    {
        Boxes b = view_boxes(boxes_obj);
        uint32_t flags = sort ? LOCD_FIND_SORTED : 0u;
        std::unique_lock<std::mutex> lock(mutex_, std::defer_lock);
        locd_status st;
        {
            py::gil_scoped_release nogil;
            lock.lock();
            if (!engine_)
                st = LOCD_ERR_INVALID_HANDLE;
            else if (b.f64)
                st = locd_engine_find_pairs_f64(engine_, static_cast<const double *>(b.data), b.n, flags, pairs_.p);
            else
                st = locd_engine_find_pairs_f32(engine_, static_cast<const float *>(b.data), b.n, flags, pairs_.p);
        }
        if (st == LOCD_ERR_INVALID_HANDLE && !engine_)
            raise_closed();
        if (st != LOCD_OK)
            raise_status(st);
        // Still holding the lock: nobody else may refill pairs_ meanwhile.
        return pairs_to_array(pairs_.p, wide);
    }

    // The two-set query: (i in a, j in b). A float32 set meeting a float64
    // one is widened to float64 (exact: every float is a double).
    py::array find_pairs_between(py::handle a_obj, py::handle b_obj, bool sort, bool wide)
    {
        Boxes a = view_boxes(a_obj), b = view_boxes(b_obj);
        if (a.f64 != b.f64) {
            Boxes &narrow = a.f64 ? b : a;
            narrow = view_boxes(narrow.array.attr("astype")(py::module_::import("numpy").attr("float64")));
        }
        uint32_t flags = sort ? LOCD_FIND_SORTED : 0u;
        std::unique_lock<std::mutex> lock(mutex_, std::defer_lock);
        locd_status st;
        {
            py::gil_scoped_release nogil;
            lock.lock();
            if (!engine_)
                st = LOCD_ERR_INVALID_HANDLE;
            else if (a.f64)
                st = locd_engine_find_pairs_between_f64(engine_, static_cast<const double *>(a.data), a.n,
                                                        static_cast<const double *>(b.data), b.n, flags, pairs_.p);
            else
                st = locd_engine_find_pairs_between_f32(engine_, static_cast<const float *>(a.data), a.n,
                                                        static_cast<const float *>(b.data), b.n, flags, pairs_.p);
        }
        if (st == LOCD_ERR_INVALID_HANDLE && !engine_)
            raise_closed();
        if (st != LOCD_OK)
            raise_status(st);
        return pairs_to_array(pairs_.p, wide);
    }

    py::dict stats()
    {
        locd_stats s;
        locd_stats_init(&s);
        locd_status st;
        {
            py::gil_scoped_release nogil;
            std::lock_guard<std::mutex> lock(mutex_);
            st = engine_ ? locd_engine_get_stats(engine_, &s) : LOCD_ERR_INVALID_HANDLE;
        }
        if (st != LOCD_OK)
            raise_status(st);
        return stats_to_dict(s);
    }

    locd_engine *handle() const { return engine_; }
    std::mutex &mutex() { return mutex_; }

private:
    locd_engine *engine_ = nullptr;
    PairsBuffer pairs_;
    std::mutex mutex_;
};

// A submitted job. Python's locd.Job (a concurrent.futures.Future) waits on
// it from a thread of its own and adds the future's semantics on top.
//
// mutex_ guards job_, but is never held across the blocking locd_job_wait:
// cancel() (which wakes that wait) must not queue behind it. release()
// cancels, and the C job is freed by whoever leaves last: release() itself,
// or the last wait() still inside locd_job_wait. (No condition variable:
// GCC 12's std::condition_variable::wait needs GLIBCXX_3.4.30, which would
// raise the wheel's manylinux tag.)
class Job {
public:
    explicit Job(locd_job *job) : job_(job) {}
    ~Job() { release(); }

    // The job's status as it is: LOCD_PENDING, LOCD_OK or its error.
    int32_t poll()
    {
        py::gil_scoped_release nogil;
        std::lock_guard<std::mutex> lock(mutex_);
        return job_ ? locd_job_poll(job_) : LOCD_ERR_CANCELLED;
    }

    // LOCD_OK, LOCD_ERR_TIMEOUT or LOCD_ERR_CANCELLED; the job's other
    // errors raise.
    int32_t wait(int64_t timeout_ms)
    {
        locd_status st;
        {
            py::gil_scoped_release nogil;
            locd_job *job;
            {
                std::lock_guard<std::mutex> lock(mutex_);
                job = job_;
                if (job)
                    waiters_++;
            }
            if (!job)
                return LOCD_ERR_CANCELLED;
            st = locd_job_wait(job, timeout_ms);
            bool last;
            {
                std::lock_guard<std::mutex> lock(mutex_);
                last = --waiters_ == 0 && !job_;
            }
            if (last) // released meanwhile: the job is ours to free
                locd_job_release(job);
        }
        return checked(st);
    }

    py::array take(bool wide)
    {
        PairsBuffer out;
        locd_status st;
        {
            py::gil_scoped_release nogil;
            std::lock_guard<std::mutex> lock(mutex_);
            st = job_ ? locd_job_take(job_, out.p) : LOCD_ERR_INVALID_HANDLE;
        }
        if (st != LOCD_OK)
            raise_status(st);
        return pairs_to_array(out.p, wide);
    }

    py::dict stats()
    {
        locd_stats s;
        locd_stats_init(&s);
        locd_status st;
        {
            py::gil_scoped_release nogil;
            std::lock_guard<std::mutex> lock(mutex_);
            st = job_ ? locd_job_get_stats(job_, &s) : LOCD_ERR_INVALID_HANDLE;
        }
        if (st != LOCD_OK)
            raise_status(st);
        return stats_to_dict(s);
    }

    void cancel()
    {
        locd_status st;
        {
            py::gil_scoped_release nogil;
            std::lock_guard<std::mutex> lock(mutex_);
            st = job_ ? locd_job_cancel(job_) : LOCD_OK;
        }
        if (st != LOCD_OK)
            raise_status(st);
    }

    // Frees the C job (cancelling it if it still runs). Later calls report
    // the job as cancelled.
    void release()
    {
        py::gil_scoped_release nogil;
        locd_job *job;
        bool now;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            job = job_;
            if (!job)
                return;
            job_ = nullptr;
            now = waiters_ == 0;
            if (!now)
                locd_job_cancel(job); // wakes the waiters; the last one frees the job
        }
        if (now)
            locd_job_release(job);
    }

private:
    int32_t checked(locd_status st)
    {
        if (st == LOCD_OK || st == LOCD_ERR_TIMEOUT || st == LOCD_ERR_CANCELLED)
            return st;
        raise_status(st);
    }

    locd_job *job_ = nullptr;
    std::mutex mutex_;
    int waiters_ = 0; // threads inside locd_job_wait
};

Job *submit(Engine &engine, py::handle boxes_obj, bool sort)
{
    Boxes b = view_boxes(boxes_obj);
    uint32_t flags = sort ? LOCD_FIND_SORTED : 0u;
    locd_job *job = nullptr;
    locd_status st;
    {
        // submit copies the boxes, so the caller may reuse its array at once.
        py::gil_scoped_release nogil;
        std::lock_guard<std::mutex> lock(engine.mutex());
        if (!engine.handle())
            st = LOCD_ERR_INVALID_HANDLE;
        else if (b.f64)
            st = locd_engine_submit_f64(engine.handle(), static_cast<const double *>(b.data), b.n, flags, &job);
        else
            st = locd_engine_submit_f32(engine.handle(), static_cast<const float *>(b.data), b.n, flags, &job);
    }
    if (st == LOCD_ERR_INVALID_HANDLE && !engine.handle())
        raise_closed();
    if (st != LOCD_OK)
        raise_status(st);
    return new Job(job);
}

// The level-3 service hosted in this process: locd_service_run on a thread
// of its own (no Python code runs there, so it never needs the GIL).
class Service {
public:
    Service(py::object listen, py::object secret, uint32_t threads, uint32_t engine_threads)
    {
        locd_service_config cfg;
        locd_service_config_init(&cfg);
        std::string listen_s, secret_s;
        if (!listen.is_none()) {
            listen_s = listen.cast<std::string>();
            cfg.listen = listen_s.c_str();
        }
        if (!secret.is_none()) {
            secret_s = secret.cast<std::string>();
            cfg.secret = secret_s.c_str();
        }
        cfg.threads = threads;
        cfg.engine_threads = engine_threads;
        locd_status st;
        {
            py::gil_scoped_release nogil;
            st = locd_service_create(&cfg, &service_);
        }
        if (st != LOCD_OK)
            raise_status(st);
        address_ = locd_service_address(service_);
        thread_ = std::thread([this]() { run_status_ = locd_service_run(service_); });
    }

    ~Service() { stop(); }

    void stop()
    {
        py::gil_scoped_release nogil;
        std::lock_guard<std::mutex> lock(mutex_);
        if (!service_)
            return;
        locd_service_stop(service_);
        thread_.join();
        locd_service_destroy(service_);
        service_ = nullptr;
    }

    const std::string &address() const { return address_; }
    bool stopped() const { return service_ == nullptr; }
    int32_t run_status() const { return run_status_; }

private:
    locd_service *service_ = nullptr;
    std::string address_;
    std::thread thread_;
    std::mutex mutex_;
    locd_status run_status_ = LOCD_OK;
};

py::array brute_force(py::handle boxes_obj, bool wide)
{
    Boxes b = view_boxes(boxes_obj);
    PairsBuffer out;
    locd_status st;
    {
        py::gil_scoped_release nogil;
        st = b.f64 ? locd_brute_force_f64(static_cast<const double *>(b.data), b.n, out.p)
                   : locd_brute_force_f32(static_cast<const float *>(b.data), b.n, out.p);
    }
    if (st != LOCD_OK)
        raise_status(st);
    return pairs_to_array(out.p, wide);
}

} // namespace

// locd.Scene's extension class (scene.cpp).
void locd_bind_scene(py::module_ &m);

PYBIND11_MODULE(_core, m)
{
    m.doc() = "Compiled core of locd (pybind11). Use the `locd` package, not this module.";

    m.def("version", []() { return std::string(locd_version_string()); },
          "Version string of the loaded C library.");
    m.def("brute_force", &brute_force, py::arg("boxes"), py::arg("wide") = false,
          "O(n^2) reference: every overlapping pair, sorted by (i, j).");
    m.def("_buffer_address", [](py::handle boxes) {
        Boxes b = view_boxes(boxes);
        return reinterpret_cast<uintptr_t>(b.data);
    }, py::arg("boxes"), "Address of the buffer find_pairs would hand to C (for the zero-copy test).");

    py::class_<Engine>(m, "Engine")
        .def(py::init<int32_t, uint32_t, uint32_t, int32_t, bool, py::object, py::object, py::object, int64_t>(),
             py::arg("level"), py::arg("threads"), py::arg("max_depth"), py::arg("cell_bias"), py::arg("cubes"),
             py::arg("service"), py::arg("secret"), py::arg("worker_path"), py::arg("service_timeout_ms") = 0)
        .def("find_pairs", &Engine::find_pairs, py::arg("boxes"), py::arg("sort"), py::arg("wide") = false)
        .def("find_pairs_between", &Engine::find_pairs_between, py::arg("a"), py::arg("b"), py::arg("sort"),
             py::arg("wide") = false)
        .def("stats", &Engine::stats)
        .def("close", &Engine::close)
        .def_property_readonly("closed", &Engine::closed)
        .def_property_readonly("level", &Engine::level)
        .def_property_readonly("threads", &Engine::threads)
        .def("submit", &submit, py::arg("boxes"), py::arg("sort"), py::keep_alive<0, 1>());

    py::class_<Service>(m, "Service")
        .def(py::init<py::object, py::object, uint32_t, uint32_t>(), py::arg("listen"), py::arg("secret"),
             py::arg("threads"), py::arg("engine_threads"))
        .def("stop", &Service::stop)
        .def_property_readonly("address", &Service::address)
        .def_property_readonly("stopped", &Service::stopped)
        .def_property_readonly("run_status", &Service::run_status);

    py::class_<Job>(m, "Job")
        .def("poll", &Job::poll)
        .def("wait", &Job::wait, py::arg("timeout_ms"))
        .def("take", &Job::take, py::arg("wide") = false)
        .def("stats", &Job::stats)
        .def("cancel", &Job::cancel)
        .def("release", &Job::release);

    locd_bind_scene(m);
}
