#include "field/sparse_field.hpp"
#include "common/huge_pages.hpp"

namespace meniscus {

SparseField::SparseField(SampleLattice lattice, std::vector<uint64_t> block_keys, float background)
    : lattice_(lattice), block_keys_(std::move(block_keys)), background_(background) {
  assign_populated(values_, block_keys_.size() * kBlockSamples, background);
  index_.build(block_keys_);
}

SparseField::SparseField(SampleLattice lattice, std::vector<uint64_t> block_keys, float background, Unwritten)
    : lattice_(lattice), block_keys_(std::move(block_keys)), background_(background) {
  values_.resize(block_keys_.size() * kBlockSamples);
  index_.build(block_keys_);
}

}  // namespace meniscus
