// The rank communicator on 1..4 ranks: sums equal the rank-ordered sum bit
// for bit, the other reductions and the byte collectives give every rank
// the expected values, and exchange() delivers messages of any size
// (including none) matched by (peer, tag).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "halo/comm.hpp"

namespace lbdem::halo {
namespace {

const Comm& comm() { return Comm::world(); }

// A value per rank whose sum depends on the order of the additions: on 3
// ranks, left to right gives (1 + 1e16) - 1e16 = 0 and right to left 1; on 4,
// a pairwise tree gives 0 where left to right gives 0.5.
double value_of(int r) {
  constexpr double v[] = {1.0, 1.0e16, -1.0e16, 0.5};
  return r < 4 ? v[r] : 0.1 * r + 1.0 / (3.0 + r);
}

std::vector<std::byte> bytes_of(const std::string& s) {
  std::vector<std::byte> b(s.size());
  std::memcpy(b.data(), s.data(), s.size());
  return b;
}
std::string string_of(const std::vector<std::byte>& b) {
  return std::string(reinterpret_cast<const char*>(b.data()), b.size());
}

TEST(Comm, RanksAndNodes) {
  const Comm& c = comm();
  ASSERT_GE(c.size(), 1);
  EXPECT_GE(c.rank(), 0);
  EXPECT_LT(c.rank(), c.size());
  EXPECT_GE(c.local_rank(), 0);
  EXPECT_LT(c.local_rank(), c.local_size());
  EXPECT_LE(c.local_size(), c.size());
  EXPECT_EQ(c.distributed(), c.size() > 1);
  EXPECT_EQ(c.root(), c.rank() == 0);
  // Under Open MPI's launcher the rank count is the launcher's.
  if (const char* n = std::getenv("OMPI_COMM_WORLD_SIZE")) {
    EXPECT_EQ(c.size(), std::atoi(n));
    EXPECT_NE(c.native(), nullptr);
    EXPECT_NE(c.describe().find("mpi"), std::string::npos) << c.describe();
  }
  EXPECT_LE(c.node(), c.rank());
  EXPECT_GE(c.node(), 0);
  if (c.local_size() == c.size()) {
    EXPECT_EQ(c.node(), 0);  // one node: its lowest rank is 0
  }
  if (!c.distributed()) {
    EXPECT_EQ(c.local_size(), 1);
  }
  c.barrier();
}

TEST(Comm, SumIsTheRankOrderedSumBitForBit) {
  const Comm& c = comm();
  double expect = value_of(0);
  for (int r = 1; r < c.size(); ++r) expect += value_of(r);
  const double got = c.sum(value_of(c.rank()));
  EXPECT_EQ(std::memcmp(&got, &expect, sizeof got), 0) << got << " vs " << expect;

  // Element-wise, in place; element i of rank r is value_of(r) * (i + 1).
  std::vector<double> v(7);
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = value_of(c.rank()) * static_cast<double>(i + 1);
  c.sum(std::span<double>(v));
  for (std::size_t i = 0; i < v.size(); ++i) {
    double e = value_of(0) * static_cast<double>(i + 1);
    for (int r = 1; r < c.size(); ++r) e += value_of(r) * static_cast<double>(i + 1);
    EXPECT_EQ(std::memcmp(&v[i], &e, sizeof e), 0) << "element " << i;
  }

  // A negative zero stays negative on one rank (the sum starts from rank 0's value).
  if (c.size() == 1) {
    EXPECT_TRUE(std::signbit(c.sum(-0.0)));
  }

  const long n = c.size();
  EXPECT_EQ(c.sum(static_cast<long>(c.rank() + 1)), n * (n + 1) / 2);
}

TEST(Comm, MaxMinMaxloc) {
  const Comm& c = comm();
  const int last = c.size() - 1;
  EXPECT_EQ(c.max(0.5 * c.rank()), 0.5 * last);
  EXPECT_EQ(c.min(-0.5 * c.rank()), -0.5 * last);
  EXPECT_EQ(c.max(static_cast<long>(c.rank()) - 10), static_cast<long>(last) - 10);
  EXPECT_EQ(c.min(static_cast<long>(c.rank()) + 3), 3L);

  // A unique largest value on the last rank.
  auto [v, r] = c.maxloc(c.rank() == last ? 9.0 : 1.0 * c.rank());
  EXPECT_EQ(v, 9.0);
  EXPECT_EQ(r, last);
  // Ties go to the lowest rank: every rank but 0 holds the largest value.
  auto [tv, tr] = c.maxloc(c.rank() == 0 ? -1.0 : 4.0);
  EXPECT_EQ(tv, c.size() == 1 ? -1.0 : 4.0);
  EXPECT_EQ(tr, c.size() == 1 ? 0 : 1);
}

TEST(Comm, AnyAll) {
  const Comm& c = comm();
  const int last = c.size() - 1;
  EXPECT_TRUE(c.any(c.rank() == last));
  EXPECT_FALSE(c.any(false));
  EXPECT_TRUE(c.all(c.rank() >= 0));
  EXPECT_FALSE(c.all(c.rank() != last));
  EXPECT_EQ(c.all(c.rank() != 0), false);
}

TEST(Comm, BroadcastFromAnyRoot) {
  const Comm& c = comm();
  for (int root = 0; root < c.size(); ++root) {
    const std::string payload = "from rank " + std::to_string(root) + std::string(static_cast<std::size_t>(root) * 13, 'x');
    std::vector<std::byte> b = c.rank() == root ? bytes_of(payload) : bytes_of("stale content on another rank");
    c.broadcast(b, root);
    EXPECT_EQ(string_of(b), payload) << "root " << root;
  }
  std::vector<std::byte> empty = c.root() ? std::vector<std::byte>{} : bytes_of("not empty");
  c.broadcast(empty, 0);
  EXPECT_TRUE(empty.empty());
  EXPECT_THROW(c.broadcast(empty, c.size()), Error);
}

TEST(Comm, GatherAndAllgather) {
  const Comm& c = comm();
  // Rank r sends r copies of the letter 'a' + r (rank 0 sends nothing).
  const auto mine = bytes_of(std::string(static_cast<std::size_t>(c.rank()), static_cast<char>('a' + c.rank())));
  for (int root : {0, c.size() - 1}) {
    const auto all = c.gather(mine, root);
    if (c.rank() != root) {
      EXPECT_TRUE(all.empty());
      continue;
    }
    ASSERT_EQ(all.size(), static_cast<std::size_t>(c.size()));
    for (int r = 0; r < c.size(); ++r)
      EXPECT_EQ(string_of(all[static_cast<std::size_t>(r)]),
                std::string(static_cast<std::size_t>(r), static_cast<char>('a' + r)));
  }
  const auto every = c.allgather(mine);
  ASSERT_EQ(every.size(), static_cast<std::size_t>(c.size()));
  for (int r = 0; r < c.size(); ++r)
    EXPECT_EQ(string_of(every[static_cast<std::size_t>(r)]),
              std::string(static_cast<std::size_t>(r), static_cast<char>('a' + r)));
}

// Around a ring. Entry i of exchange() sends to peers[i] and receives from
// peers[i]: to the next rank three messages (one whose size varies with the
// rank, zero on some; a short one; a 2 MB one) and back to the previous rank
// three (two empty); the receives from the previous rank ask for its tags in
// the opposite order. On one rank every peer is the rank itself; on two,
// next and previous are one peer, told apart by the tags.
TEST(Comm, ExchangeVariableSizesAndTagsToOnePeer) {
  const Comm& c = comm();
  const int n = c.size(), r = c.rank();
  const int next = (r + 1) % n, prev = (r + n - 1) % n;
  const auto sized = [](int rank) { return std::string(static_cast<std::size_t>((rank * 7) % 5), 'k'); };
  const auto shorter = [](int rank) { return "short from " + std::to_string(rank); };
  const auto big = [](int rank) {
    std::string s(2000000 + static_cast<std::size_t>(rank), static_cast<char>('a' + rank));
    s.back() = '!';
    return s;
  };
  const auto back = [](int rank) { return "back from " + std::to_string(rank); };

  const std::vector<int> peers{next, next, next, prev, prev, prev};
  const std::vector<int> tags{3, 1, 2, 40, 41, 42};
  const std::vector<int> recv_tags{40, 41, 42, 2, 1, 3};
  const std::vector<std::vector<std::byte>> sends{bytes_of(sized(r)), bytes_of(shorter(r)), bytes_of(big(r)),
                                                  {},                 bytes_of(back(r)),    {}};
  const auto got = c.exchange(peers, tags, sends, recv_tags);
  ASSERT_EQ(got.size(), peers.size());
  EXPECT_TRUE(got[0].empty());                 // next's tag 40
  EXPECT_EQ(string_of(got[1]), back(next));    // next's tag 41
  EXPECT_TRUE(got[2].empty());                 // next's tag 42
  EXPECT_EQ(string_of(got[3]), big(prev));     // prev's tag 2
  EXPECT_EQ(string_of(got[4]), shorter(prev)); // prev's tag 1
  EXPECT_EQ(string_of(got[5]), sized(prev));   // prev's tag 3 (empty on some ranks)

  // Nothing to exchange: returns at once with nothing.
  EXPECT_TRUE(c.exchange({}, {}, {}, {}).empty());
}

TEST(Comm, ExchangeRefusesBadInput) {
  const Comm& c = comm();
  const std::vector<std::vector<std::byte>> one{bytes_of("x")};
  const std::vector<int> bad_peer{c.size()}, zero{0}, two_tags{0, 1};
  EXPECT_THROW(c.exchange(bad_peer, zero, one, zero), Error);
  EXPECT_THROW(c.exchange(zero, two_tags, one, zero), Error);
  const std::vector<int> too_big{16001}, negative{-1};
  EXPECT_THROW(c.exchange(zero, too_big, one, zero), Error);
  EXPECT_THROW(c.exchange(zero, zero, one, negative), Error);
  // A receive from itself that no send to itself matches.
  const std::vector<int> me{c.rank()}, other_tag{5};
  EXPECT_THROW(c.exchange(me, zero, one, other_tag), Error);
}

}  // namespace
}  // namespace lbdem::halo
