#pragma once

#include <memory>
#include <utility>

namespace gpatlas_core {

// An owning pointer that copies what it points to: a class that hides its state behind a pointer
// (pimpl) gets value semantics by declaring its copy and move members `= default` where T is
// complete. Like std::unique_ptr, it does not propagate const.
template <typename T>
class DeepCopyPtr {
 public:
  DeepCopyPtr() = default;
  explicit DeepCopyPtr(std::unique_ptr<T> owned) : owned_(std::move(owned)) {}
  DeepCopyPtr(const DeepCopyPtr& other) : owned_(copyOf(other)) {}
  DeepCopyPtr& operator=(const DeepCopyPtr& other) {
    if (this != &other) owned_ = copyOf(other);
    return *this;
  }
  DeepCopyPtr(DeepCopyPtr&&) noexcept = default;
  DeepCopyPtr& operator=(DeepCopyPtr&&) noexcept = default;
  ~DeepCopyPtr() = default;

  T& operator*() const { return *owned_; }
  T* operator->() const { return owned_.get(); }

 private:
  static std::unique_ptr<T> copyOf(const DeepCopyPtr& other) {
    return other.owned_ ? std::make_unique<T>(*other.owned_) : nullptr;
  }
  std::unique_ptr<T> owned_;
};

}  // namespace gpatlas_core
