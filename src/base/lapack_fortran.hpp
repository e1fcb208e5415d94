#pragma once
// Private prototypes of the Fortran 77 routines kfx calls directly (not installed, not part of the
// API). Conventions of gfortran, which built both Debian's OpenBLAS/LAPACK and SLICOT:
//  - every argument is passed by reference; INTEGER is 32-bit int, LOGICAL is a 4-byte int;
//  - arrays are column-major (Eigen's default MatrixXd layout);
//  - each CHARACTER argument adds a hidden string length, passed by value after all the
//    regular arguments, in the order of the CHARACTER arguments (type size_t for gfortran >= 8).
// Only the routines below are used; the references are the routines' own documentation headers.
#include <cstddef>

extern "C" {

using kfx_fortran_logical = int;

/// LAPACK DGETRF: LU factorization with partial pivoting of a general m x n matrix, in place.
/// info > 0: U(info, info) is exactly zero (the factorization is complete, U is singular).
void dgetrf_(const int* m, const int* n, double* a, const int* lda, int* ipiv, int* info);

/// LAPACK DGETRS: solves A X = B (trans 'N') with the LU factors and pivots from DGETRF.
void dgetrs_(const char* trans, const int* n, const int* nrhs, const double* a, const int* lda, const int* ipiv,
             double* b, const int* ldb, int* info, std::size_t trans_len);

/// LAPACK DGEEV: eigenvalues (and optionally eigenvectors) of a general real matrix. Used with
/// jobvl = jobvr = 'N' (eigenvalues only); lwork = -1 is a workspace query.
void dgeev_(const char* jobvl, const char* jobvr, const int* n, double* a, const int* lda, double* wr, double* wi,
            double* vl, const int* ldvl, double* vr, const int* ldvr, double* work, const int* lwork, int* info,
            std::size_t jobvl_len, std::size_t jobvr_len);

/// LAPACK DSYEVR: selected eigenvalues of a symmetric matrix (range 'I' with il = iu = 1 gives the
/// smallest); lwork = liwork = -1 is a workspace query. The input triangle is destroyed.
void dsyevr_(const char* jobz, const char* range, const char* uplo, const int* n, double* a, const int* lda,
             const double* vl, const double* vu, const int* il, const int* iu, const double* abstol, int* m, double* w,
             double* z, const int* ldz, int* isuppz, double* work, const int* lwork, int* iwork, const int* liwork,
             int* info, std::size_t jobz_len, std::size_t range_len, std::size_t uplo_len);

/// LAPACK DPOTRF: Cholesky factorization of a symmetric matrix (uplo 'L': A = L L^T, the lower
/// triangle is read and overwritten by L). info > 0: the leading minor of order info is not
/// positive (a pivot <= 0 or NaN), the factorization could not be completed.
void dpotrf_(const char* uplo, const int* n, double* a, const int* lda, int* info, std::size_t uplo_len);

/// SLICOT SB02OD: continuous/discrete algebraic Riccati equation by the generalized Schur method
/// (deflating subspaces of the extended symplectic pencil, Van Dooren 1981). For dico = 'D':
///   X = A^T X A - (L + A^T X B) (R + B^T X B)^{-1} (L + A^T X B)^T + Q.
/// Arrays: a (n x n), b (n x m), q (n x n), r (m x m), l (n x m), x (n x n), alfar/alfai/beta (2n),
/// s (ldS >= 2n+m, 2n+m columns), t (ldT >= 2n+m, 2n columns), u (2n x 2n), iwork (max(1, m, 2n)),
/// dwork (ldwork >= max(14n+23, 16n, 2n+m, 3m)), bwork (2n). info: 0 ok, 1 singular extended
/// pencil, 2 QZ failed, 3 reordering failed, 4 eigenvalues moved across the circle after reordering,
/// 5 stable subspace dimension != n (eigenvalues on the unit circle), 6 singular U11 (rcond < eps).
void sb02od_(const char* dico, const char* jobb, const char* fact, const char* uplo, const char* jobl, const char* sort,
             const int* n, const int* m, const int* p, const double* a, const int* lda, const double* b, const int* ldb,
             double* q, const int* ldq, double* r, const int* ldr, double* l, const int* ldl, double* rcond, double* x,
             const int* ldx, double* alfar, double* alfai, double* beta, double* s, const int* lds, double* t,
             const int* ldt, double* u, const int* ldu, const double* tol, int* iwork, double* dwork, const int* ldwork,
             kfx_fortran_logical* bwork, int* info, std::size_t dico_len, std::size_t jobb_len, std::size_t fact_len,
             std::size_t uplo_len, std::size_t jobl_len, std::size_t sort_len);

/// SLICOT SB03MD: continuous or discrete Lyapunov equation by the Schur method (Bartels-Stewart,
/// Barraud). For dico = 'D': op(A)^T X op(A) - X = scale * C, op(A) = A (trana = 'N') or A^T
/// ('T'); C (n x n, symmetric) is overwritten by X; a is overwritten by its Schur form and u by the
/// Schur vectors (fact = 'N'); wr/wi receive the eigenvalues of A. ldwork >= max(n*n, 3n) for
/// job = 'X' (2n^2 + 2n to be safe across SLICOT releases). info: 0 ok, 1..n QR failed,
/// n+1 A has (almost) reciprocal eigenvalues, perturbed values were used.
void sb03md_(const char* dico, const char* job, const char* fact, const char* trana, const int* n, double* a,
             const int* lda, double* u, const int* ldu, double* c, const int* ldc, double* scale, double* sep,
             double* ferr, double* wr, double* wi, int* iwork, double* dwork, const int* ldwork, int* info,
             std::size_t dico_len, std::size_t job_len, std::size_t fact_len, std::size_t trana_len);

/// LAPACK DGEES: real Schur form A = Z T Z^T (jobvs = 'V'), sort = 'N' (select not referenced).
/// wr/wi: eigenvalues in the order of the diagonal of T; lwork = -1 is a workspace query.
void dgees_(const char* jobvs, const char* sort, kfx_fortran_logical (*select)(const double*, const double*),
            const int* n, double* a, const int* lda, int* sdim, double* wr, double* wi, double* vs, const int* ldvs,
            double* work, const int* lwork, kfx_fortran_logical* bwork, int* info, std::size_t jobvs_len,
            std::size_t sort_len);

/// LAPACK DTRSEN: reorders a real Schur form so that the selected eigenvalues (select(j) true; a
/// complex pair is moved together) lead the diagonal; with compq = 'V' the Schur vectors q are
/// updated. job = 'N': no condition numbers (lwork >= max(1, n), liwork >= 1). info = 1: reordering
/// failed (T too close to having the selected and other eigenvalues equal).
void dtrsen_(const char* job, const char* compq, const kfx_fortran_logical* select, const int* n, double* t,
             const int* ldt, double* q, const int* ldq, double* wr, double* wi, int* m, double* s, double* sep,
             double* work, const int* lwork, int* iwork, const int* liwork, int* info, std::size_t job_len,
             std::size_t compq_len);

/// SLICOT SG02AD: descriptor Riccati equations by the generalized Schur method (deflating subspaces of
/// the extended pencil, Van Dooren 1981). For dico = 'D':
///   E^T X E = A^T X A - (L + A^T X B) (R + B^T X B)^{-1} (L + A^T X B)^T + Q   (E nonsingular).
/// scal 'G' scales Q, R, L; acc 'R' refines the final linear solve. Arrays: s, t (lds = ldt >= 2n+m;
/// 2n+m and 2n columns), u (2n x 2n), iwork (max(1, m, 2n)), dwork (>= max(14n+23, 16n, 2n+m, 3m)),
/// bwork (2n). info: 1 singular extended pencil, 2 QZ failed, 3 reordering failed, 4 eigenvalues moved
/// across the circle, 5 stable subspace dimension != n, 6 spectrum too close to the circle (solution not
/// symmetric), 7 singular U11. iwarn 1: the solution may be inaccurate.
void sg02ad_(const char* dico, const char* jobb, const char* fact, const char* uplo, const char* jobl, const char* scal,
             const char* sort, const char* acc, const int* n, const int* m, const int* p, const double* a,
             const int* lda, const double* e, const int* lde, const double* b, const int* ldb, double* q,
             const int* ldq, double* r, const int* ldr, double* l, const int* ldl, double* rcondu, double* x,
             const int* ldx, double* alfar, double* alfai, double* beta, double* s, const int* lds, double* t,
             const int* ldt, double* u, const int* ldu, const double* tol, int* iwork, double* dwork, const int* ldwork,
             kfx_fortran_logical* bwork, int* iwarn, int* info, std::size_t dico_len, std::size_t jobb_len,
             std::size_t fact_len, std::size_t uplo_len, std::size_t jobl_len, std::size_t scal_len,
             std::size_t sort_len, std::size_t acc_len);

/// SLICOT SG03AD: generalized Lyapunov equations (Bartels-Stewart on the generalized Schur form, Penzl
/// 1998). For dico = 'D', trans = 'T': A X A^T - E X E^T = scale * Y (x holds Y on entry, X on exit;
/// a, e overwritten by the Schur factors, q, z by the orthogonal factors). job 'X': iwork not
/// referenced, ldwork >= max(1, 4n, 8n+16). info: 2 QZ failed, 3 reciprocal eigenvalue pair
/// (perturbed values used; X returned).
void sg03ad_(const char* dico, const char* job, const char* fact, const char* trans, const char* uplo, const int* n,
             double* a, const int* lda, double* e, const int* lde, double* q, const int* ldq, double* z, const int* ldz,
             double* x, const int* ldx, double* scale, double* sep, double* ferr, double* alphar, double* alphai,
             double* beta, int* iwork, double* dwork, const int* ldwork, int* info, std::size_t dico_len,
             std::size_t job_len, std::size_t fact_len, std::size_t trans_len, std::size_t uplo_len);

/// SLICOT SB04QD: discrete-time Sylvester equation X + A X B = C (Hessenberg-Schur method, Golub, Nash,
/// Van Loan 1979); A n x n and B m x m overwritten, C n x m overwritten by X, z (m x m) the Schur
/// vectors of B; iwork (4n), ldwork >= max(1, 2n^2 + 9n, 5m, n + m). info: 1..m QR failed on B,
/// > m a singular system (an eigenvalue pair with lambda_i(A) lambda_j(B) = -1).
void sb04qd_(const int* n, const int* m, double* a, const int* lda, double* b, const int* ldb, double* c,
             const int* ldc, double* z, const int* ldz, int* iwork, double* dwork, const int* ldwork, int* info);

}  // extern "C"
