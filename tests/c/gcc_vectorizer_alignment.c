/* A miscompilation of GCC 12.2 (Debian 12.2.0-14), kept as a reproducer: with
       gcc -O3 -march=x86-64-v4 gcc_vectorizer_alignment.c && ./a.out
   the loop storing into the local array R is vectorized with aligned stores (vmovapd, 32 bytes)
   while R is placed at an address that is 16 mod 32, and the program dies with SIGSEGV. The
   vectorizer's log (-fdump-tree-vect-details) says "force alignment of R[...]"; the frame layout
   does not honour it. There is no undefined behaviour here (every index is within R). Declaring
   R with __attribute__((aligned(64))) makes the program run; gpmegen's generated C declares
   every local array so (templates/model.c.j2, ALIGNED). Prints a number and exits 0 when the
   compiler is right. */
#include <stdio.h>

enum { N = 28, NI = 27 };

__attribute__((noinline)) static void consume(double *r, int n)
{
    for (int i = 1; i < n; ++i) {
        r[0] += r[i];
    }
}

__attribute__((noinline)) static double reduce(const double *M, const int *ind, const double *x)
{
    double R[NI * NI], z[NI];
    for (int i = 0; i < NI; ++i) {
        const double *row = M + ind[i] * N;
        z[i] = row[0];
        for (int j = i; j < NI; ++j) {
            R[i * NI + j] = row[ind[j]] - x[i] * x[j];
        }
    }
    consume(R, NI * NI);
    consume(z, NI);
    return R[0] + z[0];
}

int main(void)
{
    double M[N * N], x[NI];
    int ind[NI];
    for (int i = 0; i < N * N; ++i) {
        M[i] = i;
    }
    for (int i = 0; i < NI; ++i) {
        ind[i] = i + 1;
        x[i] = 1.0;
    }
    printf("%g\n", reduce(M, ind, x));
    return 0;
}
