// meniscus — the CPU backend's buffer, with the interface of the device's DeviceBuffer
// (cuda/cuda_check.hpp), so that code shared by the backends allocates its arrays as
// BufferOf<B, T> and runs unchanged on either: uninitialised storage of n elements that resize
// does not keep, zero(), one element back with get(), copies in and out.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <utility>

#include "common/for_each.hpp"

namespace meniscus {

template <class T>
class HostBuffer {
 public:
  HostBuffer() = default;
  explicit HostBuffer(std::size_t n) { resize(n); }
  HostBuffer(HostBuffer&&) noexcept = default;
  HostBuffer& operator=(HostBuffer&&) noexcept = default;
  HostBuffer(const HostBuffer&) = delete;
  HostBuffer& operator=(const HostBuffer&) = delete;

  /// Reallocates (contents are not kept) to n elements; n = 0 frees.
  void resize(std::size_t n) {
    if (n == size_) return;
    data_.reset();
    size_ = 0;
    if (n > 0) data_ = std::make_unique_for_overwrite<T[]>(n);
    size_ = n;
  }
  void zero() {
    if (size_ > 0) std::memset(static_cast<void*>(data_.get()), 0, size_ * sizeof(T));
  }
  void upload(const T* host, std::size_t n) {
    resize(n);
    std::copy_n(host, n, data_.get());
  }
  void download(T* host, std::size_t n) const {
    if (n > size_) throw std::out_of_range("HostBuffer::download: more elements than the buffer holds");
    std::copy_n(data_.get(), n, host);
  }
  T get(std::size_t i) const { return data_[i]; }
  void copy_from(const HostBuffer& o) {
    resize(o.size_);
    std::copy_n(o.data_.get(), size_, data_.get());
  }
  T* data() { return data_.get(); }
  const T* data() const { return data_.get(); }
  std::size_t size() const { return size_; }

 private:
  std::unique_ptr<T[]> data_;
  std::size_t size_ = 0;
};

/// The buffer template of backend B, specialised by each backend (the device's in cuda/device.hpp).
template <class B>
struct BackendBuffer;
template <>
struct BackendBuffer<Host> {
  template <class T>
  using type = HostBuffer<T>;
};

/// The buffer of backend B (Host or cuda::Device).
template <class B, class T>
using BufferOf = typename BackendBuffer<B>::template type<T>;

}  // namespace meniscus
