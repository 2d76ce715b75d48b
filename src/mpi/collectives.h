/// \file collectives.h
/// \brief The MPI collectives of the distributed graph and TIN builders, over plain bytes: counts are
/// exchanged first, then the data, and every message size is checked against MPI's int counts.
#pragma once

#include <mpi.h>

#include <climits>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace mpi {
namespace collective {

/// n as an MPI count; throws dw::Error naming `what` when one message would exceed INT_MAX bytes.
inline int toInt(std::size_t n, const char* what) {
  if (n > static_cast<std::size_t>(INT_MAX))
    throw Error(std::string("dw::mpi: ") + what + " exceeds 2 GiB for one message; use more ranks");
  return static_cast<int>(n);
}

/// Displacements of `counts` (exclusive prefix sums), each checked as an MPI count.
inline std::vector<int> displacements(const std::vector<int>& counts, const char* what) {
  std::vector<int> d(counts.size(), 0);
  std::size_t total = 0;
  for (std::size_t r = 0; r < counts.size(); ++r) d[r] = toInt(total, what), total += counts[r];
  toInt(total, what);
  return d;
}

/// Alltoallv of plain bytes; send[r] goes to rank r, the result holds what rank r sent at [r].
inline std::vector<std::vector<unsigned char>> exchangeBytes(
    MPI_Comm comm, const std::vector<std::vector<unsigned char>>& send) {
  const int P = static_cast<int>(send.size());
  std::vector<int> sc(P), sd(P, 0), rc(P), rd(P, 0);
  std::size_t total = 0;
  for (int r = 0; r < P; ++r) sc[r] = toInt(send[r].size(), "a halo message"), total += send[r].size();
  toInt(total, "one rank's halo messages");
  for (int r = 1; r < P; ++r) sd[r] = sd[r - 1] + sc[r - 1];
  MPI_Alltoall(sc.data(), 1, MPI_INT, rc.data(), 1, MPI_INT, comm);
  std::size_t rtotal = 0;
  for (int r = 0; r < P; ++r) rd[r] = toInt(rtotal, "one rank's halo messages"), rtotal += rc[r];
  toInt(rtotal, "one rank's halo messages");
  std::vector<unsigned char> sbuf(total), rbuf(rtotal);
  for (int r = 0; r < P; ++r)
    if (!send[r].empty()) std::memcpy(sbuf.data() + sd[r], send[r].data(), send[r].size());
  MPI_Alltoallv(sbuf.data(), sc.data(), sd.data(), MPI_BYTE, rbuf.data(), rc.data(), rd.data(), MPI_BYTE,
                comm);
  std::vector<std::vector<unsigned char>> out(P);
  for (int r = 0; r < P; ++r) out[r].assign(rbuf.begin() + rd[r], rbuf.begin() + rd[r] + rc[r]);
  return out;
}

/// Alltoallv of records grouped by destination: `send` holds send_n[0] records for rank 0, then
/// send_n[1] for rank 1, ...; the result is what every rank sent here, in rank order. The size errors
/// name one message, what one rank sends and what it receives.
template <class T>
std::vector<T> exchangeRecords(MPI_Comm comm, const std::vector<T>& send,
                               const std::vector<std::size_t>& send_n, const char* message, const char* sent,
                               const char* received) {
  const int P = static_cast<int>(send_n.size());
  std::vector<int> scount(P), rcount(P);
  for (int r = 0; r < P; ++r) scount[r] = toInt(send_n[r] * sizeof(T), message);
  std::vector<int> sdispl(P, 0), rdispl(P, 0);
  for (int r = 1; r < P; ++r) sdispl[r] = sdispl[r - 1] + scount[r - 1];
  toInt(send.size() * sizeof(T), sent);
  MPI_Alltoall(scount.data(), 1, MPI_INT, rcount.data(), 1, MPI_INT, comm);
  std::size_t rbytes = rcount[0];
  for (int r = 1; r < P; ++r) rdispl[r] = toInt(rbytes, received), rbytes += rcount[r];
  toInt(rbytes, received);
  std::vector<T> got(rbytes / sizeof(T));
  MPI_Alltoallv(send.data(), scount.data(), sdispl.data(), MPI_BYTE, got.data(), rcount.data(), rdispl.data(),
                MPI_BYTE, comm);
  return got;
}

/// Appends v's bytes to a message.
template <class T>
void put(std::vector<unsigned char>& b, const T& v) {
  const unsigned char* c = reinterpret_cast<const unsigned char*>(&v);
  b.insert(b.end(), c, c + sizeof(T));
}

/// Reads a T at `at` of a message and advances `at`; a short message is an internal inconsistency.
template <class T>
T get(const std::vector<unsigned char>& b, std::size_t& at) {
  if (at + sizeof(T) > b.size()) throw Error("dw::mpi: internal inconsistency: short halo message");
  T v;
  std::memcpy(&v, b.data() + at, sizeof(T));
  at += sizeof(T);
  return v;
}

/// Gathers variable-length arrays of T from every rank onto every rank (rank order).
template <class T>
std::vector<T> allGather(MPI_Comm comm, const std::vector<T>& mine) {
  int P = 1;
  MPI_Comm_size(comm, &P);
  const int bytes = toInt(mine.size() * sizeof(T), "a gathered array");
  std::vector<int> counts(P);
  MPI_Allgather(&bytes, 1, MPI_INT, counts.data(), 1, MPI_INT, comm);
  const std::vector<int> displs = displacements(counts, "a gathered array");
  std::vector<T> all(std::size_t(displs[P - 1] + counts[P - 1]) / sizeof(T));
  MPI_Allgatherv(mine.data(), bytes, MPI_BYTE, all.data(), counts.data(), displs.data(), MPI_BYTE, comm);
  return all;
}

/// Gathers variable-length arrays of T onto rank 0 only (rank order); `what` names the gathered whole
/// in the size error.
template <class T>
std::vector<T> gatherTo0(MPI_Comm comm, const std::vector<T>& mine, const char* what = "the gathered graph") {
  int P = 1, me = 0;
  MPI_Comm_size(comm, &P);
  MPI_Comm_rank(comm, &me);
  const int bytes = toInt(mine.size() * sizeof(T), "a gathered array");
  std::vector<int> counts(P), displs(P, 0);
  MPI_Gather(&bytes, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, comm);
  std::vector<T> all;
  if (me == 0) {
    std::size_t total = 0;
    for (int r = 0; r < P; ++r) displs[r] = toInt(total, "a gathered array"), total += counts[r];
    toInt(total, what);
    all.resize(total / sizeof(T));
  }
  MPI_Gatherv(mine.data(), bytes, MPI_BYTE, all.data(), counts.data(), displs.data(), MPI_BYTE, 0, comm);
  return all;
}

/// This rank's first global index and the total, for `mine` items per rank numbered in rank order.
struct RankRange {
  std::uint64_t first = 0, total = 0;
};
inline RankRange rankRange(MPI_Comm comm, std::uint64_t mine) {
  int me = 0;
  MPI_Comm_rank(comm, &me);
  RankRange r;
  MPI_Exscan(&mine, &r.first, 1, MPI_UINT64_T, MPI_SUM, comm);
  if (me == 0) r.first = 0;  // MPI_Exscan leaves rank 0's result undefined
  MPI_Allreduce(&mine, &r.total, 1, MPI_UINT64_T, MPI_SUM, comm);
  return r;
}

}  // namespace collective
}  // namespace mpi
}  // namespace dw
