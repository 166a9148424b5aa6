#pragma once
// Open-addressing hash table from a packed 63-bit block key to a shared block: linear probing over a
// power-of-two array, load factor <= 1/2, backward-shift deletion (no tombstones). A lookup is one
// multiply-shift hash and, at this load, about one probe; std::unordered_map costs a modulo and a
// pointer chase per lookup, which dominated merged point queries.
//
// Copying the table copies the shared pointers (blocks are shared, see MergedMap's copy-on-write).

#include <bit>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

namespace vog::map {

template <class Block>
class BlockTable {
 public:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};  // never a packed key (top bit unused)

  std::size_t size() const { return size_; }
  std::size_t capacity() const { return slots_.size(); }

  Block* find(std::uint64_t key) const {
    if (slots_.empty()) return nullptr;
    for (std::size_t i = home(key);; i = (i + 1) & mask_) {
      const Slot& s = slots_[i];
      if (s.key == key) return s.block.get();
      if (s.key == kEmpty) return nullptr;
    }
  }

  // The slot of `key`, inserted empty (null block) when missing.
  std::shared_ptr<Block>& slot(std::uint64_t key) {
    if (2 * (size_ + 1) > slots_.size()) grow();
    for (std::size_t i = home(key);; i = (i + 1) & mask_) {
      Slot& s = slots_[i];
      if (s.key == key) return s.block;
      if (s.key == kEmpty) {
        s.key = key;
        ++size_;
        return s.block;
      }
    }
  }

  bool erase(std::uint64_t key) {
    if (slots_.empty()) return false;
    std::size_t i = home(key);
    while (slots_[i].key != key) {
      if (slots_[i].key == kEmpty) return false;
      i = (i + 1) & mask_;
    }
    // Backward shift: move later members of the probe run into the hole when their home allows it.
    std::size_t hole = i;
    for (std::size_t j = (i + 1) & mask_; slots_[j].key != kEmpty; j = (j + 1) & mask_) {
      const std::size_t h = home(slots_[j].key);
      const bool movable = hole <= j ? (h <= hole || h > j) : (h <= hole && h > j);
      if (movable) {
        slots_[hole] = std::move(slots_[j]);
        hole = j;
      }
    }
    slots_[hole].key = kEmpty;
    slots_[hole].block.reset();
    --size_;
    return true;
  }

  template <class F>
  void forEach(F&& f) const {
    for (const Slot& s : slots_) {
      if (s.key != kEmpty) f(s.key, s.block);
    }
  }

  std::size_t memoryBytes() const { return slots_.size() * sizeof(Slot); }

 private:
  struct Slot {
    std::uint64_t key = kEmpty;
    std::shared_ptr<Block> block;
  };

  std::size_t home(std::uint64_t key) const {
    // Fibonacci hashing of a mixed key: packed block coordinates differ mostly in low bits.
    key ^= key >> 29;
    return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> shift_) & mask_;
  }

  void grow() {
    std::vector<Slot> old = std::move(slots_);
    const std::size_t capacity = old.empty() ? 64 : 2 * old.size();
    slots_.assign(capacity, Slot{});
    mask_ = capacity - 1;
    shift_ = 64 - static_cast<int>(std::countr_zero(capacity));
    size_ = 0;
    for (Slot& s : old) {
      if (s.key != kEmpty) slot(s.key) = std::move(s.block);
    }
  }

  std::vector<Slot> slots_;
  std::size_t size_ = 0;
  std::size_t mask_ = 0;
  int shift_ = 64;
};

}  // namespace vog::map
