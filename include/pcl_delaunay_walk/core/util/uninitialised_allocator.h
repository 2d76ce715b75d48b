/// \file uninitialised_allocator.h
/// \brief A std::allocator whose value-less construct() leaves trivial elements uninitialised.
///
/// Why: `std::vector::resize(n)` normally writes every new element. For the 3D kernel's tetrahedron
/// arrays a parallel pass sizes them for its whole expected growth; writing that on one thread took
/// 0.13 s of a 4M-point 16-thread build, and it made pages resident that the pass might never use
/// (its estimate is generous). With this allocator `resize(n)` only moves the end; the slots are
/// written when a thread takes them. `resize(n, value)` and copies still construct as usual.
#pragma once

#include <memory>
#include <new>
#include <type_traits>
#include <utility>

namespace dw {

template <class T>
struct UninitialisedAllocator : std::allocator<T> {
  static_assert(std::is_trivially_default_constructible<T>::value, "for trivial element types only");
  template <class U>
  struct rebind {
    using other = UninitialisedAllocator<U>;
  };
  UninitialisedAllocator() noexcept = default;
  template <class U>
  UninitialisedAllocator(const UninitialisedAllocator<U>&) noexcept {}

  template <class U>
  void construct(U* p) noexcept {
    ::new (static_cast<void*>(p)) U;  // default-initialisation: no write
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

template <class T, class U>
bool operator==(const UninitialisedAllocator<T>&, const UninitialisedAllocator<U>&) noexcept {
  return true;
}
template <class T, class U>
bool operator!=(const UninitialisedAllocator<T>&, const UninitialisedAllocator<U>&) noexcept {
  return false;
}

}  // namespace dw
