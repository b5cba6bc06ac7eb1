// A C++17 program built against an installed locd (scripts/ci/steps/12-consumers.sh):
//   c++ -std=c++17 -Wall -Wextra -Wpedantic -Werror app.cpp $(pkg-config --cflags --libs locd)
// std::optional and structured bindings fail to compile if the pkg-config
// flags put an older -std after ours (FCL's -std=c++11 used to).
#include <locd/locd.h>
#include <locd/scene.h>

#include <array>
#include <cstdio>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

namespace {

struct engine_deleter {
    void operator()(locd_engine *e) const { locd_engine_destroy(e); }
};
struct pairs_deleter {
    void operator()(locd_pairs *p) const { locd_pairs_destroy(p); }
};

std::optional<std::vector<std::pair<uint32_t, uint32_t>>> find_pairs(const std::vector<std::array<double, 6>> &boxes)
{
    locd_engine_config cfg;
    locd_engine_config_init(&cfg);
    locd_engine *e = nullptr;
    locd_pairs *p = nullptr;
    if (locd_engine_create(&cfg, &e) != LOCD_OK)
        return std::nullopt;
    std::unique_ptr<locd_engine, engine_deleter> engine(e);
    if (locd_pairs_create(nullptr, &p) != LOCD_OK)
        return std::nullopt;
    std::unique_ptr<locd_pairs, pairs_deleter> pairs(p);
    if (locd_engine_find_pairs_f64(engine.get(), boxes.data()->data(), boxes.size(), LOCD_FIND_SORTED, pairs.get()) !=
        LOCD_OK)
        return std::nullopt;
    std::vector<std::pair<uint32_t, uint32_t>> out;
    const uint32_t *d = locd_pairs_data(pairs.get());
    for (size_t k = 0; k < locd_pairs_count(pairs.get()); k++)
        out.emplace_back(d[2 * k], d[2 * k + 1]);
    return out;
}

} // namespace

int main()
{
    const std::vector<std::array<double, 6>> boxes = {
        {0, 0, 0, 1, 1, 1}, {1, 0, 0, 2, 1, 1}, {5, 5, 5, 6, 6, 6}, {0.5, 0.5, 0.5, 1.5, 1.5, 1.5}};
    const auto pairs = find_pairs(boxes);
    if (!pairs) {
        std::fprintf(stderr, "locd: %s\n", locd_last_error());
        return 1;
    }
    const std::vector<std::pair<uint32_t, uint32_t>> expected = {{0, 1}, {0, 3}, {1, 3}};
    for (const auto &[i, j] : *pairs)
        std::printf("%u %u\n", i, j);
    const bool ok = *pairs == expected;
    std::printf("c++17 consumer: %s\n", ok ? "ok" : "WRONG");
    return ok ? 0 : 1;
}
