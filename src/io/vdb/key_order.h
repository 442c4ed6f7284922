// key_order.h — indices ordered by a packed 3D key, ties by index (internal
// to the bridge; C++ only).
//
// Why: the surfacing bins every particle three times (occupancy cells, the
// neighbourhoods' cells, the kernels' leaves), each a sort of (key, index)
// pairs. The keys pack three 21-bit coordinates (most significant first),
// and a body's coordinates span a small box, so a counting sort over that
// box gives the same order (stable: ties by index) in a few passes over the
// particles instead of a comparison sort. Chunks are fixed (not per
// thread), so the result is the same for any thread count; where the box
// is too large for counters, a comparison sort gives the same order.
#ifndef KF_VDB_KEY_ORDER_H
#define KF_VDB_KEY_ORDER_H

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <utility>
#include <vector>

namespace kf_vdb {

// The distinct keys ascending (key), where each one's indices start in
// order (at, with n last), and the indices 0..n-1 ordered by key, ties by
// index (order).
template <class Index> struct key_bins {
    std::vector<Index> order;
    std::vector<uint64_t> key;
    std::vector<uint32_t> at;
};

template <class Index> key_bins<Index> order_by_key(const std::vector<uint64_t> &keys) {
    const size_t n = keys.size();
    if (uint64_t(n) >= (uint64_t(1) << 32)) throw std::runtime_error("more than 2^32 particles to bin");
    key_bins<Index> r;
    r.order.resize(n);
    if (n == 0) {
        r.at.push_back(0);
        return r;
    }
    constexpr uint64_t F = (uint64_t(1) << 21) - 1;
    // the keys' box, field by field (chunk by chunk, then combined)
    constexpr size_t CHUNKS = 16;
    const size_t chunk = (n + CHUNKS - 1) / CHUNKS;
    uint64_t clo[CHUNKS][3], chi[CHUNKS][3];
    tbb::parallel_for(tbb::blocked_range<size_t>(0, CHUNKS, 1), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t c = rg.begin(); c != rg.end(); c++) {
            uint64_t l[3] = {F, F, F}, h[3] = {0, 0, 0};
            for (size_t i = c * chunk; i < std::min(n, (c + 1) * chunk); i++)
                for (int f = 0; f < 3; f++) {
                    const uint64_t v = keys[i] >> (21 * f) & F;
                    l[f] = std::min(l[f], v), h[f] = std::max(h[f], v);
                }
            for (int f = 0; f < 3; f++) clo[c][f] = l[f], chi[c][f] = h[f];
        }
    });
    uint64_t lo[3] = {F, F, F}, hi[3] = {0, 0, 0};
    for (size_t c = 0; c < CHUNKS; c++)
        for (int f = 0; f < 3; f++) lo[f] = std::min(lo[f], clo[c][f]), hi[f] = std::max(hi[f], chi[c][f]);
    const uint64_t e0 = hi[0] - lo[0] + 1, e1 = hi[1] - lo[1] + 1, e2 = hi[2] - lo[2] + 1;
    const size_t nbox = e0 * e1 * e2 <= (uint64_t(1) << 26) ? size_t(e0 * e1 * e2) : 0;
    if (nbox == 0 || nbox > 4 * n + 4096) {
        // a sparse box: the comparison sort, the same order
        std::vector<std::pair<uint64_t, Index>> kp(n);
        tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t> &rg) {
            for (size_t i = rg.begin(); i != rg.end(); i++) kp[i] = {keys[i], Index(i)};
        });
        tbb::parallel_sort(kp.begin(), kp.end());
        for (size_t q = 0; q < n; q++) {
            r.order[q] = kp[q].second;
            if (q == 0 || kp[q].first != kp[q - 1].first) r.key.push_back(kp[q].first), r.at.push_back(uint32_t(q));
        }
        r.at.push_back(uint32_t(n));
        return r;
    }
    // a key's place in the box, in the keys' order (field 2 most significant)
    auto slot = [&](uint64_t k) {
        return size_t((((k >> 42 & F) - lo[2]) * e1 + ((k >> 21 & F) - lo[1])) * e0 + ((k & F) - lo[0]));
    };
    // chunks of the input, each counted and then placed on its own
    std::vector<uint32_t> cnt(CHUNKS * nbox, 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, CHUNKS, 1), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t c = rg.begin(); c != rg.end(); c++) {
            uint32_t *h = cnt.data() + c * nbox;
            for (size_t i = c * chunk; i < std::min(n, (c + 1) * chunk); i++) h[slot(keys[i])]++;
        }
    });
    // each chunk's first place in each slot: slots ascending, chunks in order
    uint32_t run = 0;
    for (size_t s = 0; s < nbox; s++) {
        const uint32_t s0 = run;
        for (size_t c = 0; c < CHUNKS; c++) {
            const uint32_t k = cnt[c * nbox + s];
            cnt[c * nbox + s] = run;
            run += k;
        }
        if (run != s0) {
            // the slot's key rebuilt from its place in the box
            const uint64_t f0 = s % e0 + lo[0], f1 = s / e0 % e1 + lo[1], f2 = s / e0 / e1 + lo[2];
            r.key.push_back(f2 << 42 | f1 << 21 | f0), r.at.push_back(s0);
        }
    }
    r.at.push_back(uint32_t(n));
    tbb::parallel_for(tbb::blocked_range<size_t>(0, CHUNKS, 1), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t c = rg.begin(); c != rg.end(); c++) {
            uint32_t *h = cnt.data() + c * nbox;
            for (size_t i = c * chunk; i < std::min(n, (c + 1) * chunk); i++) r.order[h[slot(keys[i])]++] = Index(i);
        }
    });
    return r;
}

} // namespace kf_vdb

#endif
