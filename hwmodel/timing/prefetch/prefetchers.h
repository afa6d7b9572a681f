// The prefetchers a configuration may name (the prefetcher key): one line each in the table below. Header-only,
// so that anything that validates a TimingConfig (the RTL parameter derivation too) sees the same list.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "hwmodel/timing/prefetch/fetch_observer.h"
#include "hwmodel/timing/prefetch/next_line.h"

namespace rtu::hw {

namespace detail {

template <class P>
inline std::unique_ptr<FetchObserver> make_prefetcher(const TimingConfig& c) {
  return std::make_unique<P>(c);
}

}  // namespace detail

inline const std::vector<PrefetcherInfo>& prefetchers() {
  static const std::vector<PrefetcherInfo> table = {
      {"none", "no prefetching: only demand fetches fill the node cache", nullptr},
      {"next_line", "on a miss, the prefetch_degree lines after the fetch's last line",
       detail::make_prefetcher<NextLinePrefetcher>},
  };
  return table;
}

// The entry a prefetcher key names; null for none (TimingConfig::validate() refuses such a name).
inline const PrefetcherInfo* find_prefetcher(const std::string& name) {
  for (const PrefetcherInfo& p : prefetchers())
    if (name == p.name) return &p;
  return nullptr;
}

// The prefetchers' names, comma separated (for the refusal of an unknown one).
inline std::string prefetcher_names() {
  std::string names;
  for (const PrefetcherInfo& p : prefetchers()) names += (names.empty() ? "" : ", ") + std::string(p.name);
  return names;
}

inline std::unique_ptr<FetchObserver> make_fetch_observer(const TimingConfig& c) {
  const PrefetcherInfo* p = find_prefetcher(c.prefetcher);
  if (!p) throw std::invalid_argument("prefetcher = '" + c.prefetcher + "' is not a prefetcher");
  return p->make ? p->make(c) : nullptr;
}

}  // namespace rtu::hw
