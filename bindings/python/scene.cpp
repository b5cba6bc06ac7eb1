// locd._core.Scene: the persistent scene (include/locd/scene.h) for Python.
//
// Kept apart from core.cpp on purpose: policy (argument checking, dtype and
// scalar-or-array handling, the exceptions for stale ids) lives in
// locd/scene.py, which hands this class only arrays that are already
// C-contiguous in the exact dtype the C call reads (boxes in the scene's
// dtype, ids and attributes as uint64). This layer turns them into pointers,
// releases the GIL around every C call, and copies results into fresh numpy
// arrays.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <cstring>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "locd/scene.h"

namespace py = pybind11;

// core.cpp: the exception for a failed locd call (locd._errors' mapping).
[[noreturn]] void locd_py_raise(locd_status status, const std::string &detail, long long index);

namespace {

// Raises the Python exception for a failed scene call. Reads the
// thread-local detail first.
[[noreturn]] void scene_raise(locd_status status)
{
    locd_py_raise(status, locd_last_error(), static_cast<long long>(locd_last_error_index()));
}

// The same for a failed query: bad input raises locd.InvalidQueryError, naming the query.
[[noreturn]] void query_raise(locd_status status)
{
    const std::string detail = locd_last_error();
    const long long index = static_cast<long long>(locd_last_error_index());
    py::object exc = py::module_::import("locd._errors")
                         .attr("from_status")(status, locd_status_string(status), detail, index, true);
    PyErr_SetObject(reinterpret_cast<PyObject *>(Py_TYPE(exc.ptr())), exc.ptr());
    throw py::error_already_set();
}

// Using a closed scene: locd.ClosedError (a ValueError), as for a closed engine.
[[noreturn]] void raise_closed()
{
    py::object exc = py::module_::import("locd._errors")
                         .attr("ClosedError")(static_cast<int>(LOCD_ERR_INVALID_HANDLE), "the scene is closed");
    PyErr_SetObject(reinterpret_cast<PyObject *>(Py_TYPE(exc.ptr())), exc.ptr());
    throw py::error_already_set();
}

// An (n,) or (n, 6) etc. array as (pointer, element count), checked to be
// C-contiguous and of the expected item size (locd/scene.py converts).
template <typename T> const T *ptr_of(const py::array &a, const char *what)
{
    if (a.itemsize() != static_cast<py::ssize_t>(sizeof(T)) || !(a.flags() & py::array::c_style))
        throw py::type_error(std::string("internal: ") + what + " not converted by locd.scene");
    return static_cast<const T *>(a.data());
}

const uint64_t *opt_u64(const py::object &o)
{
    if (o.is_none())
        return nullptr;
    return ptr_of<uint64_t>(py::reinterpret_borrow<py::array>(o), "attribute");
}

py::array_t<uint64_t> rows_to_array(const locd_id *src, size_t m)
{
    py::array_t<uint64_t> out({static_cast<py::ssize_t>(m), static_cast<py::ssize_t>(2)});
    if (m)
        std::memcpy(out.mutable_data(), src, m * 2 * sizeof(locd_id));
    return out;
}

py::array_t<uint64_t> ids_to_array(const std::vector<locd_id> &ids, size_t m)
{
    py::array_t<uint64_t> out(static_cast<py::ssize_t>(m));
    if (m)
        std::memcpy(out.mutable_data(), ids.data(), m * sizeof(locd_id));
    return out;
}

// One level-1 engine and the scene on it. The mutex serializes Python
// threads sharing a Scene (the C scene allows one changer at a time); it is
// only taken with the GIL released.
class Scene {
public:
    Scene(uint32_t threads, bool f64, uint64_t capacity_hint) : f64_(f64)
    {
        locd_engine_config cfg;
        locd_engine_config_init(&cfg);
        cfg.level = LOCD_LEVEL_INPROCESS;
        cfg.threads = threads;
        locd_scene_config sc;
        locd_scene_config_init(&sc);
        sc.capacity_hint = capacity_hint;
        locd_status st;
        {
            py::gil_scoped_release nogil;
            st = locd_engine_create(&cfg, &engine_);
            if (st == LOCD_OK)
                st = locd_scene_create(engine_, &sc, &scene_);
        }
        if (st != LOCD_OK) {
            std::string detail = locd_last_error();
            close();
            // Re-raise with the detail of the failing call.
            locd_py_raise(st, detail, -1);
        }
    }

    ~Scene() { close(); }

    void close()
    {
        py::gil_scoped_release nogil;
        std::lock_guard<std::mutex> lock(mutex_);
        locd_scene_destroy(scene_); // before its engine
        scene_ = nullptr;
        locd_engine_destroy(engine_);
        engine_ = nullptr;
    }

    bool closed() const { return scene_ == nullptr; }
    bool f64() const { return f64_; }

    uint32_t threads()
    {
        uint32_t n = 0;
        run([&]() {
            n = locd_engine_threads(engine_);
            return LOCD_OK;
        });
        return n;
    }

    size_t count()
    {
        size_t n = 0;
        run([&]() {
            n = locd_scene_count(scene_);
            return LOCD_OK;
        });
        return n;
    }

    py::array_t<uint64_t> add(const py::array &boxes, bool is_static, uint64_t category, uint64_t mask,
                              uint64_t group, uint64_t user, const py::object &categories,
                              const py::object &masks, const py::object &groups, const py::object &users)
    {
        size_t n = static_cast<size_t>(boxes.shape(0));
        locd_scene_add_options opt;
        locd_scene_add_options_init(&opt);
        opt.flags = is_static ? LOCD_OBJECT_STATIC : 0u;
        opt.category = category;
        opt.mask = mask;
        opt.group = group;
        opt.user = user;
        opt.categories = opt_u64(categories);
        opt.masks = opt_u64(masks);
        opt.groups = opt_u64(groups);
        opt.users = opt_u64(users);
        py::array_t<uint64_t> ids(static_cast<py::ssize_t>(n));
        locd_id *out = ids.mutable_data();
        const void *b = f64_ ? static_cast<const void *>(ptr_of<double>(boxes, "boxes"))
                             : static_cast<const void *>(ptr_of<float>(boxes, "boxes"));
        run([&]() {
            return f64_ ? locd_scene_add_f64(scene_, static_cast<const double *>(b), n, &opt, out)
                        : locd_scene_add_f32(scene_, static_cast<const float *>(b), n, &opt, out);
        });
        return ids;
    }

    void move(const py::array &ids, const py::array &boxes)
    {
        size_t n = static_cast<size_t>(ids.shape(0));
        const locd_id *id = ptr_of<uint64_t>(ids, "ids");
        const void *b = f64_ ? static_cast<const void *>(ptr_of<double>(boxes, "boxes"))
                             : static_cast<const void *>(ptr_of<float>(boxes, "boxes"));
        run([&]() {
            return f64_ ? locd_scene_move_f64(scene_, id, static_cast<const double *>(b), n)
                        : locd_scene_move_f32(scene_, id, static_cast<const float *>(b), n);
        });
    }

    void remove(const py::array &ids)
    {
        size_t n = static_cast<size_t>(ids.shape(0));
        const locd_id *id = ptr_of<uint64_t>(ids, "ids");
        run([&]() { return locd_scene_remove(scene_, id, n); });
    }

    void set_filter(const py::array &ids, const py::object &categories, const py::object &masks,
                    const py::object &groups)
    {
        size_t n = static_cast<size_t>(ids.shape(0));
        const locd_id *id = ptr_of<uint64_t>(ids, "ids");
        const uint64_t *c = opt_u64(categories), *m = opt_u64(masks), *g = opt_u64(groups);
        run([&]() { return locd_scene_set_filter(scene_, id, n, c, m, g); });
    }

    void set_user(const py::array &ids, const py::array &users)
    {
        size_t n = static_cast<size_t>(ids.shape(0));
        const locd_id *id = ptr_of<uint64_t>(ids, "ids");
        const uint64_t *u = ptr_of<uint64_t>(users, "users");
        run([&]() { return locd_scene_set_user(scene_, id, n, u); });
    }

    py::array_t<uint64_t> get_user(const py::array &ids)
    {
        size_t n = static_cast<size_t>(ids.shape(0));
        const locd_id *id = ptr_of<uint64_t>(ids, "ids");
        py::array_t<uint64_t> out(static_cast<py::ssize_t>(n));
        uint64_t *u = out.mutable_data();
        run([&]() { return locd_scene_get_user(scene_, id, n, u); });
        return out;
    }

    // Updates and returns (pairs, created, lost), copied while the lock is held
    // (the scene's lists are valid only until its next change).
    py::tuple update(bool pairs, bool events)
    {
        uint32_t flags = (pairs ? LOCD_SCENE_UPDATE_PAIRS : 0u) | (events ? LOCD_SCENE_UPDATE_EVENTS : 0u);
        std::vector<locd_id> lists[3];
        size_t counts[3] = {0, 0, 0};
        locd_status st;
        {
            py::gil_scoped_release nogil;
            std::lock_guard<std::mutex> lock(mutex_);
            st = scene_ ? locd_scene_update(scene_, flags) : LOCD_ERR_INVALID_HANDLE;
            locd_status (*getters[3])(const locd_scene *, const locd_id **, size_t *) = {
                locd_scene_pairs, locd_scene_created, locd_scene_lost};
            for (int k = 0; k < 3 && st == LOCD_OK; k++) {
                const locd_id *src = nullptr;
                st = getters[k](scene_, &src, &counts[k]);
                if (st == LOCD_OK && counts[k])
                    lists[k].assign(src, src + 2 * counts[k]);
            }
        }
        check(st);
        return py::make_tuple(rows_to_array(lists[0].data(), counts[0]), rows_to_array(lists[1].data(), counts[1]),
                              rows_to_array(lists[2].data(), counts[2]));
    }

    py::dict stats()
    {
        locd_scene_stats s;
        locd_scene_stats_init(&s);
        run([&]() { return locd_scene_get_stats(scene_, &s); });
        py::dict d;
        d["threads"] = s.threads;
        d["objects"] = s.objects;
        d["static_objects"] = s.static_objects;
        d["moved"] = s.moved;
        d["reencoded"] = s.reencoded;
        d["entries"] = s.entries;
        d["candidates"] = s.candidates;
        d["pairs"] = s.pairs;
        d["created"] = s.created;
        d["lost"] = s.lost;
        d["rebuilt"] = s.rebuilt != 0;
        d["coasted"] = s.coasted;
        d["ms_total"] = s.ms_total;
        d["ms_encode"] = s.ms_encode;
        d["ms_merge"] = s.ms_merge;
        d["ms_sweep"] = s.ms_sweep;
        d["ms_events"] = s.ms_events;
        return d;
    }

    // Overlaps: kind 0 box (6 values), 1 point (3), 2 sphere (3 and radius). Float64 always: a query is
    // exact in float64 whatever the scene's precision, and no finite value overflows.
    py::array_t<uint64_t> overlap(int kind, const py::array &shape, double radius, uint64_t mask)
    {
        const double *q = ptr_of<double>(shape, "query");
        locd_query_filter f;
        locd_query_filter_init(&f);
        f.mask = mask;
        std::vector<locd_id> ids;
        size_t m = 0;
        grow_until_fits(ids, nullptr, m, [&](locd_id *out, double *, size_t cap, size_t *count) {
            if (kind == 0)
                return locd_scene_overlap_box_f64(scene_, q, &f, out, cap, count);
            if (kind == 1)
                return locd_scene_overlap_point_f64(scene_, q, &f, out, cap, count);
            return locd_scene_overlap_sphere_f64(scene_, q, radius, &f, out, cap, count);
        });
        return ids_to_array(ids, m);
    }

    // Casts: kind 0 ray (origin), 1 box (6 values); every hit sorted by (t, id), or the mode's one.
    py::tuple cast(int kind, const py::array &from, const py::array &direction, double max_t, uint32_t mode,
                   uint64_t mask)
    {
        const double *o = ptr_of<double>(from, "origin"), *d = ptr_of<double>(direction, "direction");
        locd_query_filter f;
        locd_query_filter_init(&f);
        f.mask = mask;
        std::vector<locd_id> ids;
        std::vector<double> ts;
        size_t m = 0;
        grow_until_fits(ids, &ts, m, [&](locd_id *out, double *t, size_t cap, size_t *count) {
            return kind == 0 ? locd_scene_cast_ray_f64(scene_, o, d, max_t, mode, &f, out, t, cap, count)
                             : locd_scene_cast_box_f64(scene_, o, d, max_t, mode, &f, out, t, cap, count);
        });
        py::array_t<double> t_out(static_cast<py::ssize_t>(m));
        if (m)
            std::memcpy(t_out.mutable_data(), ts.data(), m * sizeof(double));
        return py::make_tuple(ids_to_array(ids, m), t_out);
    }

    // Batches: cast kind 0 rays, 1 boxes; overlap kind 0 boxes, 1 points, 2 spheres. Every hit: (offsets
    // int64 (n+1,), ids, t) or, for overlaps, (offsets, ids); closest and any: (ids, t), 0 and inf when
    // a query hit nothing.
    py::tuple cast_batch(int kind, const py::array &from, const py::array &directions, const py::array &max_t,
                         uint32_t mode, uint64_t mask)
    {
        const double *v = ptr_of<double>(from, "origins"), *d = ptr_of<double>(directions, "directions"),
                     *mt = ptr_of<double>(max_t, "max_t");
        const size_t n = static_cast<size_t>(from.shape(0));
        return batch(true, mode, [&](const locd_query_filter *f, locd_hits *h) {
            return kind == 0 ? locd_scene_cast_ray_batch_f64(scene_, v, d, mt, n, mode, f, h)
                             : locd_scene_cast_box_batch_f64(scene_, v, d, mt, n, mode, f, h);
        }, mask);
    }

    py::tuple overlap_batch(int kind, const py::array &shapes, const py::object &radii, uint64_t mask)
    {
        const double *v = ptr_of<double>(shapes, "queries");
        const double *r = radii.is_none() ? nullptr : ptr_of<double>(py::reinterpret_borrow<py::array>(radii), "radii");
        const size_t n = static_cast<size_t>(shapes.shape(0));
        return batch(false, LOCD_HIT_ALL, [&](const locd_query_filter *f, locd_hits *h) {
            if (kind == 0)
                return locd_scene_overlap_box_batch_f64(scene_, v, n, f, h);
            if (kind == 1)
                return locd_scene_overlap_point_batch_f64(scene_, v, n, f, h);
            return locd_scene_overlap_sphere_batch_f64(scene_, v, r, n, f, h);
        }, mask);
    }

private:
    // A batch into a locd_hits of its own, copied out into numpy arrays while the lock is held.
    template <typename F> py::tuple batch(bool cast, uint32_t mode, F call, uint64_t mask)
    {
        locd_query_filter f;
        locd_query_filter_init(&f);
        f.mask = mask;
        locd_hits *h = nullptr;
        std::vector<uint64_t> off;
        std::vector<locd_id> ids;
        std::vector<double> ts;
        locd_status st;
        {
            py::gil_scoped_release nogil;
            std::lock_guard<std::mutex> lock(mutex_);
            st = !scene_ ? LOCD_ERR_INVALID_HANDLE : locd_hits_create(nullptr, &h);
            if (st == LOCD_OK)
                st = call(&f, h);
            if (st == LOCD_OK) {
                const size_t q = locd_hits_queries(h), m = locd_hits_count(h);
                off.assign(locd_hits_offsets(h), locd_hits_offsets(h) + q + 1);
                ids.assign(locd_hits_ids(h), locd_hits_ids(h) + m);
                if (cast)
                    ts.assign(locd_hits_t(h), locd_hits_t(h) + m);
            }
            locd_hits_destroy(h);
        }
        check(st, true);
        py::array_t<uint64_t> ids_out(static_cast<py::ssize_t>(ids.size()));
        if (!ids.empty())
            std::memcpy(ids_out.mutable_data(), ids.data(), ids.size() * sizeof(locd_id));
        py::array_t<double> t_out(static_cast<py::ssize_t>(ts.size()));
        if (!ts.empty())
            std::memcpy(t_out.mutable_data(), ts.data(), ts.size() * sizeof(double));
        if (cast && mode != LOCD_HIT_ALL)
            return py::tuple(py::make_tuple(ids_out, t_out));
        py::array_t<int64_t> off_out(static_cast<py::ssize_t>(off.size()));
        for (size_t k = 0; k < off.size(); k++)
            off_out.mutable_data()[k] = static_cast<int64_t>(off[k]);
        if (cast)
            return py::tuple(py::make_tuple(off_out, ids_out, t_out));
        return py::tuple(py::make_tuple(off_out, ids_out));
    }

    // Runs one C call on the scene without the GIL, under the lock; raises on
    // failure.
    template <typename F> void run(F call)
    {
        locd_status st;
        {
            py::gil_scoped_release nogil;
            std::lock_guard<std::mutex> lock(mutex_);
            st = scene_ ? call() : LOCD_ERR_INVALID_HANDLE;
        }
        check(st);
    }

    // A query into a buffer of our own: retried with the size the library
    // reports until the hits fit (the scene cannot change meanwhile: the
    // lock is held throughout).
    template <typename F>
    void grow_until_fits(std::vector<locd_id> &ids, std::vector<double> *ts, size_t &m, F call)
    {
        locd_status st;
        {
            py::gil_scoped_release nogil;
            std::lock_guard<std::mutex> lock(mutex_);
            size_t cap = 64;
            for (;;) {
                ids.resize(cap);
                if (ts)
                    ts->resize(cap);
                if (!scene_) {
                    st = LOCD_ERR_INVALID_HANDLE;
                    break;
                }
                st = call(ids.data(), ts ? ts->data() : nullptr, cap, &m);
                if (st != LOCD_ERR_BUFFER_TOO_SMALL || m <= cap)
                    break;
                cap = m;
            }
        }
        check(st, true);
    }

    // Raises for a failed call (query: a query's, whose bad input names the query).
    void check(locd_status st, bool query = false)
    {
        if (st == LOCD_ERR_INVALID_HANDLE && !scene_)
            raise_closed();
        if (st != LOCD_OK) {
            if (query)
                query_raise(st);
            scene_raise(st);
        }
    }

    locd_engine *engine_ = nullptr;
    locd_scene *scene_ = nullptr;
    bool f64_ = false;
    std::mutex mutex_;
};

} // namespace

// Called from PYBIND11_MODULE in core.cpp.
void locd_bind_scene(py::module_ &m)
{
    py::class_<Scene>(m, "Scene")
        .def(py::init<uint32_t, bool, uint64_t>(), py::arg("threads"), py::arg("f64"), py::arg("capacity_hint"))
        .def("close", &Scene::close)
        .def_property_readonly("closed", &Scene::closed)
        .def_property_readonly("f64", &Scene::f64)
        .def_property_readonly("threads", &Scene::threads)
        .def("count", &Scene::count)
        .def("add", &Scene::add, py::arg("boxes"), py::arg("is_static"), py::arg("category"), py::arg("mask"),
             py::arg("group"), py::arg("user"), py::arg("categories"), py::arg("masks"), py::arg("groups"),
             py::arg("users"))
        .def("move", &Scene::move, py::arg("ids"), py::arg("boxes"))
        .def("remove", &Scene::remove, py::arg("ids"))
        .def("set_filter", &Scene::set_filter, py::arg("ids"), py::arg("categories"), py::arg("masks"),
             py::arg("groups"))
        .def("set_user", &Scene::set_user, py::arg("ids"), py::arg("users"))
        .def("get_user", &Scene::get_user, py::arg("ids"))
        .def("update", &Scene::update, py::arg("pairs"), py::arg("events"))
        .def("stats", &Scene::stats)
        .def("overlap", &Scene::overlap, py::arg("kind"), py::arg("shape"), py::arg("radius"), py::arg("mask"))
        .def("cast", &Scene::cast, py::arg("kind"), py::arg("origin"), py::arg("direction"), py::arg("max_t"),
             py::arg("mode"), py::arg("mask"))
        .def("cast_batch", &Scene::cast_batch, py::arg("kind"), py::arg("origins"), py::arg("directions"),
             py::arg("max_t"), py::arg("mode"), py::arg("mask"))
        .def("overlap_batch", &Scene::overlap_batch, py::arg("kind"), py::arg("queries"), py::arg("radii"),
             py::arg("mask"));
}
