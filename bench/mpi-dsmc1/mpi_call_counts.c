/* Counts the MPI calls and bytes of one rank (PMPI interposition), for the communication
 * figures of docs/performance/mpi.md: load-independent, unlike timings. Not part of the
 * build. Usage:
 *   mpicc -O2 -shared -fPIC -o /tmp/libmpicount.so bench/mpi-dsmc1/mpi_call_counts.c
 *   mpirun -np 2 -x LD_PRELOAD=/tmp/libmpicount.so build-mpi/grainbath run ...
 * Each rank prints one line per MPI function it called at MPI_Finalize (stderr):
 *   mpicount rank R FUNCTION calls C bytes B
 * B: bytes this rank sends to other ranks (point-to-point: the message; all-to-all(v):
 * its blocks for the other ranks; all-gather(v): its contribution times (size - 1);
 * (i)all-reduce: the reduced buffer once, the algorithm's log(size) rounds not counted;
 * gather(v) to a root: its contribution unless it is the root). "Synchronisation points"
 * in the docs are the collective calls plus the blocking receives. */
#include <mpi.h>
#include <stdio.h>
#include <string.h>

enum { kIsend, kSend, kRecv, kProbe, kSendrecv, kAlltoall, kAlltoallv, kAllgather, kAllgatherv, kAllreduce,
       kIallreduce, kGather, kGatherv, kBcast, kBarrier, kReduce, kCount };
static const char* names[kCount] = {"Isend",     "Send",      "Recv",      "Probe",      "Sendrecv", "Alltoall",
                                    "Alltoallv", "Allgather", "Allgatherv", "Allreduce", "Iallreduce", "Gather",
                                    "Gatherv",   "Bcast",     "Barrier",   "Reduce"};
static long long calls[kCount], bytes[kCount];

static long long tsize(MPI_Datatype t) {
  int s = 0;
  PMPI_Type_size(t, &s);
  return s;
}
static int csize(MPI_Comm c) {
  int s = 1;
  PMPI_Comm_size(c, &s);
  return s;
}
static int crank(MPI_Comm c) {
  int r = 0;
  PMPI_Comm_rank(c, &r);
  return r;
}

int MPI_Isend(const void* b, int n, MPI_Datatype t, int d, int tag, MPI_Comm c, MPI_Request* r) {
  calls[kIsend]++, bytes[kIsend] += n * tsize(t);
  return PMPI_Isend(b, n, t, d, tag, c, r);
}
int MPI_Send(const void* b, int n, MPI_Datatype t, int d, int tag, MPI_Comm c) {
  calls[kSend]++, bytes[kSend] += n * tsize(t);
  return PMPI_Send(b, n, t, d, tag, c);
}
int MPI_Recv(void* b, int n, MPI_Datatype t, int s, int tag, MPI_Comm c, MPI_Status* st) {
  calls[kRecv]++;
  return PMPI_Recv(b, n, t, s, tag, c, st);
}
int MPI_Probe(int s, int tag, MPI_Comm c, MPI_Status* st) {
  calls[kProbe]++;
  return PMPI_Probe(s, tag, c, st);
}
int MPI_Sendrecv(const void* sb, int sn, MPI_Datatype st, int d, int stag, void* rb, int rn, MPI_Datatype rt, int s,
                 int rtag, MPI_Comm c, MPI_Status* status) {
  calls[kSendrecv]++, bytes[kSendrecv] += sn * tsize(st);
  return PMPI_Sendrecv(sb, sn, st, d, stag, rb, rn, rt, s, rtag, c, status);
}
int MPI_Alltoall(const void* sb, int sn, MPI_Datatype st, void* rb, int rn, MPI_Datatype rt, MPI_Comm c) {
  calls[kAlltoall]++, bytes[kAlltoall] += (long long)sn * tsize(st) * (csize(c) - 1);
  return PMPI_Alltoall(sb, sn, st, rb, rn, rt, c);
}
int MPI_Alltoallv(const void* sb, const int* sn, const int* sd, MPI_Datatype st, void* rb, const int* rn,
                  const int* rd, MPI_Datatype rt, MPI_Comm c) {
  calls[kAlltoallv]++;
  const int me = crank(c), p = csize(c);
  for (int r = 0; r < p; ++r)
    if (r != me) bytes[kAlltoallv] += sn[r] * tsize(st);
  return PMPI_Alltoallv(sb, sn, sd, st, rb, rn, rd, rt, c);
}
int MPI_Allgather(const void* sb, int sn, MPI_Datatype st, void* rb, int rn, MPI_Datatype rt, MPI_Comm c) {
  calls[kAllgather]++, bytes[kAllgather] += (long long)sn * tsize(st) * (csize(c) - 1);
  return PMPI_Allgather(sb, sn, st, rb, rn, rt, c);
}
int MPI_Allgatherv(const void* sb, int sn, MPI_Datatype st, void* rb, const int* rn, const int* rd, MPI_Datatype rt,
                   MPI_Comm c) {
  calls[kAllgatherv]++, bytes[kAllgatherv] += (long long)sn * tsize(st) * (csize(c) - 1);
  return PMPI_Allgatherv(sb, sn, st, rb, rn, rd, rt, c);
}
int MPI_Allreduce(const void* sb, void* rb, int n, MPI_Datatype t, MPI_Op op, MPI_Comm c) {
  calls[kAllreduce]++, bytes[kAllreduce] += n * tsize(t);
  return PMPI_Allreduce(sb, rb, n, t, op, c);
}
int MPI_Iallreduce(const void* sb, void* rb, int n, MPI_Datatype t, MPI_Op op, MPI_Comm c, MPI_Request* r) {
  calls[kIallreduce]++, bytes[kIallreduce] += n * tsize(t);
  return PMPI_Iallreduce(sb, rb, n, t, op, c, r);
}
int MPI_Gather(const void* sb, int sn, MPI_Datatype st, void* rb, int rn, MPI_Datatype rt, int root, MPI_Comm c) {
  calls[kGather]++;
  if (crank(c) != root) bytes[kGather] += sn * tsize(st);
  return PMPI_Gather(sb, sn, st, rb, rn, rt, root, c);
}
int MPI_Gatherv(const void* sb, int sn, MPI_Datatype st, void* rb, const int* rn, const int* rd, MPI_Datatype rt,
                int root, MPI_Comm c) {
  calls[kGatherv]++;
  if (crank(c) != root) bytes[kGatherv] += sn * tsize(st);
  return PMPI_Gatherv(sb, sn, st, rb, rn, rd, rt, root, c);
}
int MPI_Bcast(void* b, int n, MPI_Datatype t, int root, MPI_Comm c) {
  calls[kBcast]++;
  if (crank(c) == root) bytes[kBcast] += n * tsize(t);
  return PMPI_Bcast(b, n, t, root, c);
}
int MPI_Barrier(MPI_Comm c) {
  calls[kBarrier]++;
  return PMPI_Barrier(c);
}
int MPI_Reduce(const void* sb, void* rb, int n, MPI_Datatype t, MPI_Op op, int root, MPI_Comm c) {
  calls[kReduce]++, bytes[kReduce] += n * tsize(t);
  return PMPI_Reduce(sb, rb, n, t, op, root, c);
}
int MPI_Finalize(void) {
  const int me = crank(MPI_COMM_WORLD);
  for (int k = 0; k < kCount; ++k)
    if (calls[k]) fprintf(stderr, "mpicount rank %d %s calls %lld bytes %lld\n", me, names[k], calls[k], bytes[k]);
  return PMPI_Finalize();
}
