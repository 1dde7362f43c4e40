// meniscus — the emulated CUDA device's runtime (see cuda_runtime.h here): one device, host
// memory with an optional limit, launches run on oneTBB with a block's threads as fibers
// (ucontext) on one CPU thread, events on the steady clock.
#include <cuda_runtime.h>
#include <sys/mman.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <ucontext.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <new>
#include <pthread.h>
#include <string>
#include <unordered_map>
#include <vector>

#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/common_interface_defs.h>
#endif

namespace {

thread_local cudaError_t last_error = cudaSuccess;

struct Memory {
  std::mutex mutex;
  std::unordered_map<void*, std::size_t> sizes;
  std::size_t used = 0;
  std::size_t total() const {  // read at every call, so a test can shrink the device
    const char* v = std::getenv("MENISCUS_EMULATED_DEVICE_MEMORY");
    return v != nullptr && *v != '\0' ? std::size_t(std::stoull(v)) : std::size_t(16) << 30;
  }
};
Memory& memory() {
  static Memory m;
  return m;
}

cudaError_t fail(cudaError_t e) { return last_error = e; }

}  // namespace

struct EmulatedEvent {
  std::chrono::steady_clock::time_point time;
};

const char* cudaGetErrorString(cudaError_t e) {
  switch (e) {
    case cudaSuccess: return "no error";
    case cudaErrorInvalidValue: return "invalid argument";
    case cudaErrorMemoryAllocation: return "out of memory (emulated device)";
    case cudaErrorInvalidConfiguration: return "invalid configuration argument";
    case cudaErrorInsufficientDriver: return "CUDA driver version is insufficient for CUDA runtime version";
    case cudaErrorNoDevice: return "no CUDA-capable device is detected";
    case cudaErrorLaunchFailure:
      return "unspecified launch failure (emulated device: a barrier that not every live thread of a block reached)";
  }
  return "unknown error";
}

cudaError_t cudaGetLastError() { return std::exchange(last_error, cudaSuccess); }

cudaError_t cudaGetDeviceCount(int* count) {
  *count = 1;
  return cudaSuccess;
}

cudaError_t cudaGetDeviceProperties(cudaDeviceProp* prop, int device) {
  if (device != 0) return fail(cudaErrorInvalidValue);
  std::snprintf(prop->name, sizeof prop->name, "emulated on the CPU (MENISCUS_CUDA_EMULATION, for tests)");
  prop->totalGlobalMem = memory().total();
  prop->major = prop->minor = 0;
  return cudaSuccess;
}

cudaError_t cudaSetDevice(int device) { return device == 0 ? cudaSuccess : fail(cudaErrorInvalidValue); }

cudaError_t cudaMemGetInfo(std::size_t* free_bytes, std::size_t* total_bytes) {
  Memory& m = memory();
  std::lock_guard lock(m.mutex);
  *total_bytes = m.total();
  *free_bytes = m.used < m.total() ? m.total() - m.used : 0;
  return cudaSuccess;
}

cudaError_t cudaMalloc(void** p, std::size_t bytes) {
  Memory& m = memory();
  std::lock_guard lock(m.mutex);
  if (m.used > m.total() || bytes > m.total() - m.used) return fail(cudaErrorMemoryAllocation);
  *p = ::operator new(bytes, std::align_val_t(256), std::nothrow);
  if (*p == nullptr) return fail(cudaErrorMemoryAllocation);
  m.sizes.emplace(*p, bytes);
  m.used += bytes;
  return cudaSuccess;
}

cudaError_t cudaFree(void* p) {
  if (p == nullptr) return cudaSuccess;
  Memory& m = memory();
  std::lock_guard lock(m.mutex);
  const auto it = m.sizes.find(p);
  if (it == m.sizes.end()) return fail(cudaErrorInvalidValue);
  m.used -= it->second;
  m.sizes.erase(it);
  ::operator delete(p, std::align_val_t(256));
  return cudaSuccess;
}

cudaError_t cudaMemcpy(void* dst, const void* src, std::size_t bytes, cudaMemcpyKind) {
  if (bytes > 0) std::memmove(dst, src, bytes);
  return cudaSuccess;
}

cudaError_t cudaMemset(void* p, int value, std::size_t bytes) {
  if (bytes > 0) std::memset(p, value, bytes);
  return cudaSuccess;
}

cudaError_t cudaDeviceSynchronize() { return cudaSuccess; }

cudaError_t cudaEventCreate(cudaEvent_t* e) {
  *e = new EmulatedEvent{};
  return cudaSuccess;
}
cudaError_t cudaEventDestroy(cudaEvent_t e) {
  delete e;
  return cudaSuccess;
}
cudaError_t cudaEventRecord(cudaEvent_t e, void*) {
  e->time = std::chrono::steady_clock::now();  // launches are synchronous here
  return cudaSuccess;
}
cudaError_t cudaEventSynchronize(cudaEvent_t) { return cudaSuccess; }
cudaError_t cudaEventElapsedTime(float* ms, cudaEvent_t start, cudaEvent_t stop) {
  *ms = std::chrono::duration<float, std::milli>(stop->time - start->time).count();
  return cudaSuccess;
}

// --- a block's threads -----------------------------------------------------------------------------
//
// A block runs on one CPU thread. Its first thread (in this launch's order) runs on a fiber; if it
// ends without reaching a barrier, the kernel has none and the others run straight on the CPU
// thread's stack, one after another (a barrier reached by one of them then is a divergent barrier:
// a launch failure). Otherwise every thread gets a fiber and the block runs in passes: each pass
// resumes the threads that are ready, in an order of its own, each until it waits at a barrier or
// ends, switching straight from one fiber to the next; at the end of a pass every barrier whose
// group (block or warp) has all its live threads waiting is released. A pass with no thread ready
// while some wait is a barrier not every thread reached: a launch failure.

namespace {

std::uint64_t mix(std::uint64_t x) {  // splitmix64's finaliser
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

/// An order of `items` that depends on `seed`: as given, reversed, or shuffled.
template <class T>
void permute(std::vector<T>& items, std::uint64_t seed) {
  switch (seed % 3) {
    case 0: break;
    case 1: std::reverse(items.begin(), items.end()); break;
    default:
      for (std::size_t i = items.size(); i > 1; --i) std::swap(items[i - 1], items[(seed = mix(seed)) % i]);
  }
}

void start_switch(void** fake_stack, const void* bottom, std::size_t size) {
#if defined(__SANITIZE_ADDRESS__)
  __sanitizer_start_switch_fiber(fake_stack, bottom, size);
#else
  (void)fake_stack, (void)bottom, (void)size;
#endif
}
void finish_switch(void* fake_stack, const void** bottom, std::size_t* size) {
#if defined(__SANITIZE_ADDRESS__)
  __sanitizer_finish_switch_fiber(fake_stack, bottom, size);
#else
  (void)fake_stack, (void)bottom, (void)size;
#endif
}

constexpr std::size_t kStackBytes = std::size_t(256) << 10, kGuardBytes = 4096;

struct Stack {  // a fiber's stack, with a guard page below it
  char* base = nullptr;
  Stack() {
    void* p = mmap(nullptr, kStackBytes + kGuardBytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) throw std::bad_alloc();
    mprotect(p, kGuardBytes, PROT_NONE);
    base = static_cast<char*>(p);
  }
  Stack(const Stack&) = delete;
  Stack& operator=(const Stack&) = delete;
  ~Stack() { munmap(base, kStackBytes + kGuardBytes); }
  char* bottom() const { return base + kGuardBytes; }
};

struct Fiber {
  enum State { unstarted, ready, waiting, done };
  State state = unstarted;
  unsigned lo = 0, hi = 0;  // the threads of the barrier it waits at
  ucontext_t context{};
  std::unique_ptr<Stack> stack;
  void* fake_stack = nullptr;  // AddressSanitizer's, while suspended
};

/// The block running on this CPU thread.
struct Block {
  const std::function<void()>* body = nullptr;
  dim3 dim;
  unsigned threads = 0;
  std::uint64_t seed = 0;
  int passes = 0;
  bool probing = false;    // its first thread runs alone, to learn whether the kernel has barriers
  bool fibers = false;     // the threads run on fibers (the kernel has barriers)
  bool failed = false;     // a barrier reached by a thread straight on the CPU thread's stack
  unsigned current = 0;    // the thread running now
  std::vector<Fiber> fiber;
  std::vector<unsigned> order;  // the launch's order of the threads (kept: a block is no allocation)
  std::vector<unsigned> pass;   // the threads of this pass, in its order
  std::size_t cursor = 0;
  std::vector<int> slots;      // one value per thread, for the warp reductions
  ucontext_t scheduler{};      // the CPU thread's own stack, waiting in run_block
  void* scheduler_fake_stack = nullptr;
  const void* stack_bottom = nullptr;  // the CPU thread's stack, for AddressSanitizer
  std::size_t stack_size = 0;
};
thread_local Block block;

void set_thread(unsigned t) {
  threadIdx = {t % block.dim.x, t / block.dim.x % block.dim.y, t / (block.dim.x * block.dim.y)};
  block.current = t;
}

void fiber_main();

/// Makes thread t's fiber ready to start at fiber_main.
void prepare(unsigned t) {
  Fiber& f = block.fiber[t];
  if (!f.stack) f.stack = std::make_unique<Stack>();
  getcontext(&f.context);
  f.context.uc_stack.ss_sp = f.stack->bottom();
  f.context.uc_stack.ss_size = kStackBytes;
  f.context.uc_link = nullptr;
  makecontext(&f.context, fiber_main, 0);
  f.state = Fiber::ready;
}

/// The next thread to run, or none: ends passes (but not the probe's), releasing the barriers
/// whose every live thread waits, and starts the next pass with an order of its own.
Fiber* next_thread() {
  for (;;) {
    while (block.cursor < block.pass.size()) {
      const unsigned t = block.pass[block.cursor++];
      if (block.fiber[t].state == Fiber::unstarted) prepare(t);
      if (block.fiber[t].state == Fiber::ready) {
        set_thread(t);
        return &block.fiber[t];
      }
    }
    if (block.probing) return nullptr;
    for (unsigned t = 0; t < block.threads; ++t) {  // release the full barriers
      const Fiber& f = block.fiber[t];
      if (f.state != Fiber::waiting) continue;
      bool full = true;
      for (unsigned u = f.lo; u < f.hi && full; ++u) {
        const Fiber& g = block.fiber[u];
        full = g.state == Fiber::done || (g.state == Fiber::waiting && g.lo == f.lo && g.hi == f.hi);
      }
      if (full)
        for (unsigned u = f.lo; u < f.hi; ++u)
          if (block.fiber[u].state == Fiber::waiting) block.fiber[u].state = Fiber::ready;
    }
    block.pass.clear();
    block.cursor = 0;
    for (unsigned t = 0; t < block.threads; ++t)
      if (block.fiber[t].state == Fiber::ready) block.pass.push_back(t);
    if (block.pass.empty()) return nullptr;
    permute(block.pass, mix(block.seed + std::uint64_t(++block.passes)));
  }
}

/// Leaves the running fiber for the next ready thread's (or the CPU thread's own stack when none
/// is ready) and returns when the fiber is resumed; a fiber that has ended (`done`) never is.
void switch_away(bool done) {
  Fiber& me = block.fiber[block.current];
  Fiber* next = next_thread();
  if (next == &me) return;  // released, and first in the next pass
  if (next == nullptr) {
    start_switch(done ? nullptr : &me.fake_stack, block.stack_bottom, block.stack_size);
    swapcontext(&me.context, &block.scheduler);
  } else {
    start_switch(done ? nullptr : &me.fake_stack, next->stack->bottom(), kStackBytes);
    swapcontext(&me.context, &next->context);
  }
  finish_switch(me.fake_stack, nullptr, nullptr);
}

void fiber_main() {
  finish_switch(nullptr, nullptr, nullptr);
  (*block.body)();
  block.fiber[block.current].state = Fiber::done;
  switch_away(true);
}

/// Runs the fibers of the threads ready in the current pass (and the passes after it) until none
/// is ready, from the CPU thread's own stack.
void run_fibers() {
  Fiber* first = next_thread();
  if (first == nullptr) return;
  start_switch(&block.scheduler_fake_stack, first->stack->bottom(), kStackBytes);
  swapcontext(&block.scheduler, &first->context);
  finish_switch(block.scheduler_fake_stack, nullptr, nullptr);
}

/// The running thread waits at a barrier over threads [lo, hi) of its block.
void wait_at_barrier(unsigned lo, unsigned hi) {
  if (!block.fibers) {  // reached by a thread after the first, which reached none
    block.failed = true;
    return;
  }
  Fiber& me = block.fiber[block.current];
  me.state = Fiber::waiting;
  me.lo = lo;
  me.hi = hi;
  switch_away(false);
}

/// Runs every thread of the current block on this CPU thread; false if a barrier was not reached
/// by every live thread of its block (or warp).
bool run_block(const std::function<void()>& body, dim3 dim, std::uint64_t seed) {
  if (block.stack_bottom == nullptr) {
    pthread_attr_t attr;
    void* bottom = nullptr;
    if (pthread_getattr_np(pthread_self(), &attr) == 0) {
      pthread_attr_getstack(&attr, &bottom, &block.stack_size);
      pthread_attr_destroy(&attr);
    }
    block.stack_bottom = bottom;
  }
  block.body = &body;
  block.dim = dim;
  block.threads = dim.x * dim.y * dim.z;
  block.seed = seed;
  block.passes = 0;
  block.failed = false;
  block.fibers = true;
  if (block.fiber.size() < block.threads) block.fiber.resize(block.threads);
  block.slots.resize(block.threads);
  std::vector<unsigned>& order = block.order;
  order.resize(block.threads);
  for (unsigned t = 0; t < block.threads; ++t) {
    order[t] = t;
    block.fiber[t].state = Fiber::unstarted;
  }
  permute(order, mix(seed));

  // The first thread alone, on a fiber: it ends, or waits at the kernel's first barrier.
  block.probing = true;
  block.pass.assign(1, order[0]);
  block.cursor = 0;
  run_fibers();
  block.probing = false;
  if (block.fiber[order[0]].state == Fiber::done) {  // no barrier: the others straight on this stack
    block.fibers = false;
    for (std::size_t k = 1; k < order.size(); ++k) {
      set_thread(order[k]);
      body();
    }
    return !block.failed;
  }
  block.pass.assign(order.begin() + 1, order.end());  // barriers: every thread on a fiber, in passes
  block.cursor = 0;
  run_fibers();
  for (unsigned t = 0; t < block.threads; ++t)
    if (block.fiber[t].state != Fiber::done) return false;
  return true;
}

std::atomic<std::uint64_t> launches{0};

std::uint64_t base_seed() {
  static const std::uint64_t seed = [] {
    const char* v = std::getenv("MENISCUS_EMULATED_SEED");
    return v != nullptr && *v != '\0' ? std::uint64_t(std::stoull(v)) : std::uint64_t(0);
  }();
  return seed;
}

}  // namespace

void __syncthreads() { wait_at_barrier(0, block.threads); }

namespace meniscus::cuda::emulation {

int warp_reduce(int value, WarpOp op) {
  const unsigned t = block.current, lo = t / 32 * 32, hi = std::min(lo + 32, block.threads);
  block.slots[t] = value;
  wait_at_barrier(lo, hi);
  int r = value;
  for (unsigned u = lo; u < hi && block.fibers; ++u) {
    if (u == t || block.fiber[u].state == Fiber::done) continue;  // itself, and lanes that have exited
    const int v = block.slots[u];
    r = op == WarpOp::min ? std::min(r, v) : op == WarpOp::max ? std::max(r, v) : r + v;
  }
  wait_at_barrier(lo, hi);  // every lane has read the slots before any writes them again
  return r;
}

void run_grid(dim3 grid, dim3 threads, const std::function<void()>& body) {
  const std::size_t blocks = std::size_t(grid.x) * grid.y * grid.z;
  if (blocks == 0 || threads.x * threads.y * threads.z == 0 || threads.x * threads.y * threads.z > 1024 || grid.y > 65535 ||
      grid.z > 65535) {
    fail(cudaErrorInvalidConfiguration);
    return;
  }
  const std::uint64_t seed = mix(base_seed() + launches.fetch_add(1, std::memory_order_relaxed));
  std::atomic<bool> failed{false};
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks), [&](const auto& r) {
    for (std::size_t b = r.begin(); b != r.end(); ++b) {
      blockIdx = {unsigned(b % grid.x), unsigned(b / grid.x % grid.y), unsigned(b / (std::size_t(grid.x) * grid.y))};
      blockDim = threads;
      gridDim = grid;
      if (!run_block(body, threads, mix(seed ^ b))) failed.store(true, std::memory_order_relaxed);
    }
  });
  if (failed.load()) fail(cudaErrorLaunchFailure);
}

}  // namespace meniscus::cuda::emulation
