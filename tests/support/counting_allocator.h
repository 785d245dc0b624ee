// A counting heap for no-allocation tests (Drake's malloc-limit guard, simplified).
//
// It interposes the C allocation entry points (malloc, calloc, realloc, the aligned variants), so it
// sees every heap allocation: operator new, std containers and Eigen's aligned_malloc alike.
// Every test binary that includes this header defines COOPDYN_COUNTING_ALLOCATOR_IMPL in exactly one
// translation unit before including it. Under AddressSanitizer the sanitizer owns malloc, so the
// counter is unavailable there (kCountingAvailable == false) and the tests skip.
// Usage:
//   coopdyn::testing::AllocationCounter c;   // counts on this thread while alive
//   ... hot path ...
//   EXPECT_EQ(c.count(), 0);
#pragma once

#include <cstddef>

#if defined(__SANITIZE_ADDRESS__)
#define COOPDYN_COUNTING_AVAILABLE 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define COOPDYN_COUNTING_AVAILABLE 0
#endif
#endif
#ifndef COOPDYN_COUNTING_AVAILABLE
#define COOPDYN_COUNTING_AVAILABLE 1
#endif

namespace coopdyn::testing {

constexpr bool kCountingAvailable = COOPDYN_COUNTING_AVAILABLE;

long& thread_allocations();
bool& thread_counting();

class AllocationCounter {
 public:
  AllocationCounter() : start_(thread_allocations()) { thread_counting() = true; }
  ~AllocationCounter() { thread_counting() = false; }
  AllocationCounter(const AllocationCounter&) = delete;
  AllocationCounter& operator=(const AllocationCounter&) = delete;
  long count() const { return thread_allocations() - start_; }

 private:
  long start_;
};

}  // namespace coopdyn::testing

#ifdef COOPDYN_COUNTING_ALLOCATOR_IMPL
namespace coopdyn::testing {
// plain globals with constant initialization: safe to touch from inside malloc
static thread_local long t_allocations = 0;
static thread_local bool t_counting = false;
long& thread_allocations() { return t_allocations; }
bool& thread_counting() { return t_counting; }
}  // namespace coopdyn::testing

#if COOPDYN_COUNTING_AVAILABLE
#include <cerrno>
#include <cstdlib>
#include <malloc.h>
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
void __libc_free(void*);

static inline void coopdyn_count() {
  if (coopdyn::testing::t_counting) ++coopdyn::testing::t_allocations;
}
void* malloc(std::size_t n) noexcept {
  coopdyn_count();
  return __libc_malloc(n);
}
void* calloc(std::size_t a, std::size_t b) noexcept {
  coopdyn_count();
  return __libc_calloc(a, b);
}
void* realloc(void* p, std::size_t n) noexcept {
  coopdyn_count();
  return __libc_realloc(p, n);
}
void* memalign(std::size_t al, std::size_t n) noexcept {
  coopdyn_count();
  return __libc_memalign(al, n);
}
void* aligned_alloc(std::size_t al, std::size_t n) noexcept {
  coopdyn_count();
  return __libc_memalign(al, n);
}
int posix_memalign(void** out, std::size_t al, std::size_t n) noexcept {
  coopdyn_count();
  void* p = __libc_memalign(al, n);
  if (!p) return ENOMEM;
  *out = p;
  return 0;
}
void free(void* p) noexcept { __libc_free(p); }
}
#endif
#endif
