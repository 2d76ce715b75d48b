/// \file edge_records.h
/// \brief The walk graph's edge records: owned storage, or a view of a mapped graph file.
#pragma once

#include <cstddef>
#include <memory>
#include <utility>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/util/uninitialised_allocator.h"

namespace dw {

/// A contiguous array of EdgeRecord with the part of std::vector's interface the graph code uses.
///
/// It either owns its records (a vector whose resize(n) leaves new records unwritten: the assembly
/// writes every record on all threads, and a zero fill before that, on one thread, was 0.21 s of a
/// 4M-point build's 0.8 s assembly on 16 device threads), or it views records that live in a
/// private, copy-on-write file mapping (loadGraph), kept alive by a shared owner for as long as the
/// view exists. Element writes to a view are allowed and stay in this process (the kernel copies the
/// touched pages; the file never changes). Changing the size of a view first copies it into owned
/// storage. A copy of either kind owns its records, as a std::vector copy would.
class EdgeRecords {
 public:
  using value_type = EdgeRecord;
  using size_type = std::size_t;
  using reference = EdgeRecord&;
  using const_reference = const EdgeRecord&;
  using iterator = EdgeRecord*;
  using const_iterator = const EdgeRecord*;

  EdgeRecords() = default;
  EdgeRecords(const EdgeRecords& other) : owned_(other.begin(), other.end()) { adopt(); }
  EdgeRecords(EdgeRecords&& other) noexcept { swap(other); }
  EdgeRecords& operator=(const EdgeRecords& other) {
    if (this != &other) EdgeRecords(other).swap(*this);
    return *this;
  }
  EdgeRecords& operator=(EdgeRecords&& other) noexcept {
    EdgeRecords(std::move(other)).swap(*this);
    return *this;
  }

  /// A view of `count` records at `records`, which `owner` keeps valid (and writable, privately).
  static EdgeRecords view(EdgeRecord* records, std::size_t count, std::shared_ptr<const void> owner) {
    EdgeRecords r;
    r.data_ = count ? records : nullptr;
    r.size_ = count;
    r.owner_ = std::move(owner);
    return r;
  }

  /// True while the records are a view of a mapping rather than owned storage.
  bool isView() const { return owner_ != nullptr; }

  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  EdgeRecord* data() { return data_; }
  const EdgeRecord* data() const { return data_; }
  EdgeRecord& operator[](std::size_t k) { return data_[k]; }
  const EdgeRecord& operator[](std::size_t k) const { return data_[k]; }
  EdgeRecord& front() { return data_[0]; }
  const EdgeRecord& front() const { return data_[0]; }
  EdgeRecord& back() { return data_[size_ - 1]; }
  const EdgeRecord& back() const { return data_[size_ - 1]; }
  iterator begin() { return data_; }
  iterator end() { return data_ + size_; }
  const_iterator begin() const { return data_; }
  const_iterator end() const { return data_ + size_; }

  /// Resizes; new records are unwritten. A view is copied into owned storage first.
  void resize(std::size_t n) {
    own();
    owned_.resize(n);
    adopt();
  }
  void reserve(std::size_t n) {
    own();
    owned_.reserve(n);
    adopt();
  }
  void push_back(const EdgeRecord& e) {
    own();
    owned_.push_back(e);
    adopt();
  }
  /// Empties the array; a view releases its mapping.
  void clear() {
    owner_.reset();
    owned_.clear();
    adopt();
  }
  void swap(EdgeRecords& other) noexcept {
    owned_.swap(other.owned_);
    owner_.swap(other.owner_);
    std::swap(data_, other.data_);
    std::swap(size_, other.size_);
  }

 private:
  /// Points data_/size_ at the owned vector (after it changed) and drops any view.
  void adopt() {
    owner_.reset();
    data_ = owned_.data();
    size_ = owned_.size();
  }
  /// Copies a view into owned storage; no-op when already owned.
  void own() {
    if (!owner_) return;
    owned_.assign(data_, data_ + size_);
    adopt();
  }

  std::vector<EdgeRecord, UninitialisedAllocator<EdgeRecord>> owned_;
  EdgeRecord* data_ = nullptr;
  std::size_t size_ = 0;
  std::shared_ptr<const void> owner_;  ///< non-null: data_ views memory that this keeps alive
};

}  // namespace dw
