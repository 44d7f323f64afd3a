// Replaces every form of the global operator new/delete for the rawlog_reader target: memory
// from operator new is limited to 512 MiB alive at a time, and a request beyond that fails as
// on a machine with that much memory (std::bad_alloc, or nullptr for nothrow).
//
// MRPT's CArchive trusts the lengths and counts it reads and allocates them before reading: a
// corrupt entry asks for a std::string of up to 4 GiB, or for billions of actions in a
// CActionCollection. ASan's operator new never throws, so libFuzzer would stop there as "out of
// memory" every few hundred inputs and hardly reach the reader's own handling (MRPT's exception
// becomes LogError). The out-of-memory reproducers themselves are in fuzz/findings/rawlog_reader/.
// Memory still comes from ASan's malloc, so overflows and leaks are still found; only new/delete
// vs malloc/free mismatches are not. Every form is replaced, so that no allocation mixes these
// with ASan's own operator new.
#include <sanitizer/allocator_interface.h>

#include <atomic>
#include <cstddef>
#include <cstdlib>
#include <new>

namespace {

constexpr std::size_t kBudgetBytes = std::size_t{512} << 20;
std::atomic<std::size_t> live_bytes{0};

void* Allocate(std::size_t size, std::size_t alignment) noexcept {
  if (size > kBudgetBytes || live_bytes.load() > kBudgetBytes - size) return nullptr;
  if (size == 0) size = 1;
  void* memory = nullptr;
  if (alignment <= alignof(std::max_align_t)) {
    memory = std::malloc(size);
  } else if (posix_memalign(&memory, alignment, size) != 0) {
    memory = nullptr;
  }
  if (memory != nullptr) live_bytes += __sanitizer_get_allocated_size(memory);
  return memory;
}

void Free(void* memory) noexcept {
  if (memory == nullptr) return;
  live_bytes -= __sanitizer_get_allocated_size(memory);
  std::free(memory);
}

void* AllocateOrThrow(std::size_t size, std::size_t alignment) {
  if (void* memory = Allocate(size, alignment)) return memory;
  throw std::bad_alloc();
}

std::size_t Bytes(std::align_val_t alignment) { return static_cast<std::size_t>(alignment); }

}  // namespace

void* operator new(std::size_t size) { return AllocateOrThrow(size, 0); }
void* operator new[](std::size_t size) { return AllocateOrThrow(size, 0); }
void* operator new(std::size_t size, const std::nothrow_t&) noexcept { return Allocate(size, 0); }
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept { return Allocate(size, 0); }
void* operator new(std::size_t size, std::align_val_t alignment) {
  return AllocateOrThrow(size, Bytes(alignment));
}
void* operator new[](std::size_t size, std::align_val_t alignment) {
  return AllocateOrThrow(size, Bytes(alignment));
}
void* operator new(std::size_t size, std::align_val_t alignment, const std::nothrow_t&) noexcept {
  return Allocate(size, Bytes(alignment));
}
void* operator new[](std::size_t size, std::align_val_t alignment, const std::nothrow_t&) noexcept {
  return Allocate(size, Bytes(alignment));
}

void operator delete(void* memory) noexcept { Free(memory); }
void operator delete[](void* memory) noexcept { Free(memory); }
void operator delete(void* memory, std::size_t) noexcept { Free(memory); }
void operator delete[](void* memory, std::size_t) noexcept { Free(memory); }
void operator delete(void* memory, const std::nothrow_t&) noexcept { Free(memory); }
void operator delete[](void* memory, const std::nothrow_t&) noexcept { Free(memory); }
void operator delete(void* memory, std::align_val_t) noexcept { Free(memory); }
void operator delete[](void* memory, std::align_val_t) noexcept { Free(memory); }
void operator delete(void* memory, std::size_t, std::align_val_t) noexcept { Free(memory); }
void operator delete[](void* memory, std::size_t, std::align_val_t) noexcept { Free(memory); }
void operator delete(void* memory, std::align_val_t, const std::nothrow_t&) noexcept {
  Free(memory);
}
void operator delete[](void* memory, std::align_val_t, const std::nothrow_t&) noexcept {
  Free(memory);
}
