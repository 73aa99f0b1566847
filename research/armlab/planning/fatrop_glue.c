/* armlab: fatrop OCP C-interface glue for the optimiser's stage-wise problem (every variant).
 *
 * Robot-independent; compiled ONCE per robot kinematics and variant together with the CasADi-generated
 * stage functions (fo_*, armlab/planning/fatrop_stages.py) into one shared library linked
 * against libfatrop.so / libblasfeo.so of the casadi wheel. The joint count and the sizes
 * of the library's variant (fatrop_stages.Variant.dims) are given on the compiler's command
 * line: -DNJ (joints), -DNX (state), -DNU (full input), -DNG (rows of a stage), -DNGN (rows
 * of the last node), -DNPK (stage data per stage; the last node has its own).
 *
 * Stage vector in fatrop order: [u_k (nu[k]); x_k (NX)], nu[k] = NU - 1 or NU (NU at the
 * last interval of a segment: the next segment's duration), nu[N] = 0.
 * The generated functions use the full order [u (NU); x (NX)].
 *
 * Watchdog: every evaluation hook checks a deadline on this thread's CPU clock (fp_set_deadline:
 * a loaded machine does not trip it, a runaway solve does); past it the
 * hooks return NaN, the solver stops within an iteration, and fp_solve reports it (stats[13]).
 */
#include <stdlib.h>
#include <string.h>
#include <math.h>
#include <stdio.h>
#include <blasfeo.h>
#include <time.h>
static double cpu_now(void){struct timespec t; clock_gettime(CLOCK_THREAD_CPUTIME_ID,&t); return t.tv_sec+1e-9*t.tv_nsec;}
#include "fatrop/ocp/OCPCInterface.h"

typedef long long int casadi_int;
#define DECL(f)                                                                     \
  int f(const double **arg, double **res, casadi_int *iw, double *w, int mem);     \
  int f##_work(casadi_int *sz_arg, casadi_int *sz_res, casadi_int *sz_iw, casadi_int *sz_w);
#ifdef ONE_HESS /* one Hessian serves the exact and the "partial" solves (Variant.one_hessian) */
#define fo_hess_p fo_hess
#define fo_hess_p_work fo_hess_work
#define fo_thess_p fo_thess
#define fo_thess_p_work fo_thess_work
#endif
DECL(fo_eval)
DECL(fo_jac)
DECL(fo_hess)
DECL(fo_hess_p)
DECL(fo_grad)
DECL(fo_teval)
DECL(fo_tjac)
DECL(fo_thess)
DECL(fo_thess_p)

#ifndef NJ
#error "compile with -DNJ=<number of joints>"
#endif
#if !defined(NX) || !defined(NU) || !defined(NG) || !defined(NGN) || !defined(NPK)
#error "compile with -DNX -DNU -DNG -DNGN -DNPK (fatrop_stages.Variant.dims)"
#endif
#define NUF NU
#define NXU (NX + NUF)
#define MAXG ((NG > NGN ? NG : NGN) + 1)
#define BND 100000

typedef struct
{
  int N, K, npg, hess_exact, verbose;
  int *nu;
  double *lbx, *ubx, *lbu, *ubu, *lbg, *ubg, *Pk, *pg, *x0, *u0;
  int *gmask;
  int *n_ineq, *n_eq, *ineq_off, *eq_off, *ineq_code, *eq_code;
  double *ineq_lb, *ineq_ub, *eq_val;
  double *w;
  casadi_int *iw;
  const double *arg[16];
  double *res[16];
  double buf[(NXU + 1) * (NXU + 1 + NX + MAXG)];
  double buf2[(NXU + 1) * (MAXG + NXU + 4)];
  double ufull[NUF];
  struct FatropOcpCInterface ocp;
  struct FatropOcpCSolver *solver;
  double t_eval[5];
  double deadline; /* CLOCK_THREAD_CPUTIME_ID seconds; <= 0: none */
  int aborted;
} Prob;

/* the watchdog: 1 (and the flag set) once the deadline has passed */
static int expired(Prob *P)
{
  if (!P->aborted && P->deadline > 0 && cpu_now() > P->deadline) P->aborted = 1;
  return P->aborted;
}

static inline const double *ustage(const double *primal, const struct FatropOcpCDims *s, int k) { return primal + s->ux_offs[k]; }
static inline const double *xstage(const double *primal, const struct FatropOcpCDims *s, int k) { return primal + s->ux_offs[k] + s->nu[k]; }
/* full [u7;x19] index of fatrop-order index j at stage with nu */
static inline int fidx(int j, int nu) { return j < nu ? j : NUF + (j - nu); }

static void fill_u(Prob *P, const double *u, int nu)
{
  for (int i = 0; i < NUF; i++) P->ufull[i] = i < nu ? u[i] : 0.0;
}

static fatrop_int get_nx(fatrop_int k, void *ud) { return NX; }
static fatrop_int get_nu(fatrop_int k, void *ud) { return ((Prob *)ud)->nu[k]; }
static fatrop_int get_ng(fatrop_int k, void *ud) { return ((Prob *)ud)->n_eq[k]; }
static fatrop_int get_ng_ineq(fatrop_int k, void *ud) { return ((Prob *)ud)->n_ineq[k]; }
static fatrop_int get_K(void *ud) { return ((Prob *)ud)->K; }
static fatrop_int get_bounds(double *lo, double *up, fatrop_int k, void *ud)
{
  Prob *P = (Prob *)ud;
  int o = P->ineq_off[k];
  for (int c = 0; c < P->n_ineq[k]; c++) { lo[c] = P->ineq_lb[o + c]; up[c] = P->ineq_ub[o + c]; }
  return 0;
}
static fatrop_int get_x0(double *xk, fatrop_int k, void *ud)
{
  Prob *P = (Prob *)ud;
  memcpy(xk, P->x0 + k * NX, NX * sizeof(double));
  return 0;
}
static fatrop_int get_u0(double *uk, fatrop_int k, void *ud)
{
  Prob *P = (Prob *)ud;
  if (k < P->N) memcpy(uk, P->u0 + k * NUF, P->nu[k] * sizeof(double));
  return 0;
}

/* value of fatrop-order variable j of stage k */
static inline double varval(const double *u, const double *x, int j, int nu) { return j < nu ? u[j] : x[j - nu]; }

static fatrop_int full_obj(double scale, const double *primal, const double *sp, const double *gp, double *res,
                           const struct FatropOcpCDims *s, void *ud)
{
  Prob *P = (Prob *)ud;
  double tc0 = cpu_now();
  double F[NX], g[MAXG], l, tot = 0.0;
  for (int k = 0; k < P->N; k++)
  {
    fill_u(P, ustage(primal, s, k), P->nu[k]);
    P->arg[0] = xstage(primal, s, k); P->arg[1] = P->ufull; P->arg[2] = P->Pk + NPK * k; P->arg[3] = P->pg;
    P->res[0] = F; P->res[1] = g; P->res[2] = &l;
    fo_eval(P->arg, P->res, P->iw, P->w, 0);
    tot += l;
  }
  *res = expired(P) ? NAN : scale * tot;
  P->t_eval[0] += cpu_now() - tc0;
  return 2;
}

static fatrop_int full_obj_grad(double scale, const double *primal, const double *sp, const double *gp, double *res,
                                const struct FatropOcpCDims *s, void *ud)
{
  Prob *P = (Prob *)ud;
  double tc0 = cpu_now();
  double gr[NXU];
  for (int k = 0; k < P->N; k++)
  {
    int nu = P->nu[k];
    fill_u(P, ustage(primal, s, k), nu);
    P->arg[0] = xstage(primal, s, k); P->arg[1] = P->ufull; P->arg[2] = P->Pk + NPK * k; P->arg[3] = P->pg;
    P->res[0] = gr;
    fo_grad(P->arg, P->res, P->iw, P->w, 0);
    double *r = res + s->ux_offs[k];
    for (int j = 0; j < nu + NX; j++) r[j] = scale * gr[fidx(j, nu)];
  }
  double *r = res + s->ux_offs[P->N];
  for (int j = 0; j < NX; j++) r[j] = 0.0;
  if (expired(P)) res[0] = NAN;
  P->t_eval[0] += cpu_now() - tc0;
  return 2;
}

static fatrop_int full_cv(const double *primal, const double *sp, const double *gp, double *res,
                          const struct FatropOcpCDims *s, void *ud)
{
  Prob *P = (Prob *)ud;
  double tc0 = cpu_now();
  double F[NX], g[MAXG], l;
  for (int k = 0; k <= P->N; k++)
  {
    int nu = P->nu[k];
    const double *u = ustage(primal, s, k), *x = xstage(primal, s, k);
    if (k < P->N)
    {
      fill_u(P, u, nu);
      P->arg[0] = x; P->arg[1] = P->ufull; P->arg[2] = P->Pk + NPK * k; P->arg[3] = P->pg;
      P->res[0] = F; P->res[1] = g; P->res[2] = &l;
      fo_eval(P->arg, P->res, P->iw, P->w, 0);
      const double *xn = xstage(primal, s, k + 1);
      for (int i = 0; i < NX; i++) res[s->dyn_eq_offs[k] + i] = F[i] - xn[i];
    }
    else
    {
      P->arg[0] = x; P->arg[1] = P->Pk + NPK * k; P->arg[2] = P->pg; P->res[0] = g;
      fo_teval(P->arg, P->res, P->iw, P->w, 0);
    }
    int o = P->ineq_off[k];
    for (int c = 0; c < P->n_ineq[k]; c++)
    {
      int code = P->ineq_code[o + c];
      res[s->g_ineq_offs[k] + c] = code < BND ? g[code] : varval(u, x, code - BND, nu);
    }
    o = P->eq_off[k];
    for (int c = 0; c < P->n_eq[k]; c++)
    {
      int code = P->eq_code[o + c];
      res[s->g_offs[k] + c] = varval(u, x, code - BND, nu) - P->eq_val[o + c];
    }
  }
  if (expired(P)) res[s->dyn_eq_offs[0]] = NAN;
  P->t_eval[1] += cpu_now() - tc0;
  return 1; /* fatrop subtracts the slacks */
}

static fatrop_int full_jac(const double *primal, const double *sp, const double *gp, struct blasfeo_dmat *BAbt,
                           struct blasfeo_dmat *Ggt, struct blasfeo_dmat *Ggt_ineq, const struct FatropOcpCDims *s, void *ud)
{
  Prob *P = (Prob *)ud;
  double tc0 = cpu_now();
  double *BA = P->buf;            /* (NXU+1) x NX, column-major, full order */
  double *Gt = P->buf + (NXU + 1) * NX; /* (NXU+1) x NG */
  double *M = P->buf2;
  for (int k = 0; k <= P->N; k++)
  {
    int nu = P->nu[k], m = nu + NX + 1, ldg;
    const double *u = ustage(primal, s, k), *x = xstage(primal, s, k);
    if (k < P->N)
    {
      fill_u(P, u, nu);
      P->arg[0] = x; P->arg[1] = P->ufull; P->arg[2] = P->Pk + NPK * k; P->arg[3] = P->pg;
      P->res[0] = BA; P->res[1] = Gt;
      fo_jac(P->arg, P->res, P->iw, P->w, 0);
      const double *xn = xstage(primal, s, k + 1);
      /* BAbt: rows [u(nu); x; b], columns x_{k+1} */
      for (int c = 0; c < NX; c++)
      {
        const double *col = BA + c * (NXU + 1);
        double *d = M + c * m;
        for (int j = 0; j < nu + NX; j++) d[j] = col[fidx(j, nu)];
        d[nu + NX] = col[NXU] - xn[c];
      }
      blasfeo_pack_dmat(m, NX, M, m, &BAbt[k], 0, 0);
      ldg = NXU + 1;
    }
    else
    {
      P->arg[0] = x; P->arg[1] = P->Pk + NPK * k; P->arg[2] = P->pg; P->res[0] = Gt;
      fo_tjac(P->arg, P->res, P->iw, P->w, 0); /* (NX+1) x NGN, rows [x; g] */
      ldg = NX + 1;
    }
    /* inequality columns */
    int o = P->ineq_off[k], ni = P->n_ineq[k];
    memset(M, 0, sizeof(double) * m * (ni > 0 ? ni : 1));
    for (int c = 0; c < ni; c++)
    {
      int code = P->ineq_code[o + c];
      double *d = M + c * m;
      if (code < BND)
      {
        const double *col = Gt + code * ldg;
        if (k < P->N)
        {
          for (int j = 0; j < nu + NX; j++) d[j] = col[fidx(j, nu)];
          d[nu + NX] = col[NXU];
        }
        else
        {
          for (int j = 0; j < NX; j++) d[j] = col[j];
          d[NX] = col[NX];
        }
      }
      else
      {
        int j = code - BND;
        d[j] = 1.0;
        d[nu + NX] = varval(u, x, j, nu);
      }
    }
    if (ni > 0) blasfeo_pack_dmat(m, ni, M, m, &Ggt_ineq[k], 0, 0);
    /* equality columns (fixed variables) */
    o = P->eq_off[k];
    int ne = P->n_eq[k];
    if (ne > 0)
    {
      memset(M, 0, sizeof(double) * m * ne);
      for (int c = 0; c < ne; c++)
      {
        int j = P->eq_code[o + c] - BND;
        double *d = M + c * m;
        d[j] = 1.0;
        d[nu + NX] = varval(u, x, j, nu) - P->eq_val[o + c];
      }
      blasfeo_pack_dmat(m, ne, M, m, &Ggt[k], 0, 0);
    }
  }
  P->t_eval[2] += cpu_now() - tc0;
  return 2;
}

static fatrop_int full_hess(double scale, const double *primal, const double *lam, const double *sp, const double *gp,
                            struct blasfeo_dmat *RSQ, const struct FatropOcpCDims *s, void *ud)
{
  Prob *P = (Prob *)ud;
  double tc0 = cpu_now();
  double *H = P->buf; /* (NXU+1) x NXU full order */
  double *M = P->buf2;
  double lamg[MAXG], lamF[NX];
  for (int k = 0; k <= P->N; k++)
  {
    int nu = P->nu[k], nv = nu + NX, ld;
    const double *u = ustage(primal, s, k), *x = xstage(primal, s, k);
    memset(lamg, 0, sizeof(lamg));
    int o = P->ineq_off[k];
    for (int c = 0; c < P->n_ineq[k]; c++)
    {
      int code = P->ineq_code[o + c];
      if (code < BND) lamg[code] = lam[s->g_ineq_offs[k] + c];
    }
    if (k < P->N)
    {
      for (int i = 0; i < NX; i++) lamF[i] = lam[s->dyn_eq_offs[k] + i];
      fill_u(P, u, nu);
      P->arg[0] = x; P->arg[1] = P->ufull; P->arg[2] = P->Pk + NPK * k; P->arg[3] = P->pg;
      P->arg[4] = lamF; P->arg[5] = lamg; P->arg[6] = &scale;
      P->res[0] = H;
      if (P->hess_exact) fo_hess(P->arg, P->res, P->iw, P->w, 0);
      else fo_hess_p(P->arg, P->res, P->iw, P->w, 0);
      ld = NXU + 1;
      for (int c = 0; c < nv; c++)
      {
        const double *col = H + fidx(c, nu) * ld;
        double *d = M + c * (nv + 1);
        for (int j = 0; j < nv; j++) d[j] = col[fidx(j, nu)];
        d[nv] = col[NXU];
      }
    }
    else
    {
      P->arg[0] = x; P->arg[1] = P->Pk + NPK * k; P->arg[2] = P->pg; P->arg[3] = lamg; P->res[0] = H;
      if (P->hess_exact) fo_thess(P->arg, P->res, P->iw, P->w, 0);
      else fo_thess_p(P->arg, P->res, P->iw, P->w, 0);
      ld = NX + 1;
      for (int c = 0; c < nv; c++)
      {
        const double *col = H + c * ld;
        double *d = M + c * (nv + 1);
        for (int j = 0; j <= nv; j++) d[j] = col[j];
      }
    }
    /* bound and fixed-variable multipliers into the gradient row */
    for (int c = 0; c < P->n_ineq[k]; c++)
    {
      int code = P->ineq_code[o + c];
      if (code >= BND) M[(code - BND) * (nv + 1) + nv] += lam[s->g_ineq_offs[k] + c];
    }
    o = P->eq_off[k];
    for (int c = 0; c < P->n_eq[k]; c++)
    {
      int j = P->eq_code[o + c] - BND;
      M[j * (nv + 1) + nv] += lam[s->g_offs[k] + c];
    }
    blasfeo_pack_dmat(nv + 1, nv, M, nv + 1, &RSQ[k], 0, 0);
  }
  P->t_eval[3] += cpu_now() - tc0;
  return 2;
}

static void cb_write(const char *msg, int num) { fwrite(msg, 1, num, stdout); }
static void cb_flush(void) { fflush(stdout); }

static void *dup(const void *src, size_t bytes)
{
  void *d = malloc(bytes > 0 ? bytes : 1);
  if (src && bytes) memcpy(d, src, bytes);
  return d;
}

static int build_lists(Prob *P)
{
  int N = P->N;
  int maxrows = (N + 1) * (NG + NXU);
  if (!P->n_ineq)
  {
    P->n_ineq = malloc(sizeof(int) * (N + 1)); P->n_eq = malloc(sizeof(int) * (N + 1));
    P->ineq_off = malloc(sizeof(int) * (N + 1)); P->eq_off = malloc(sizeof(int) * (N + 1));
    P->ineq_code = malloc(sizeof(int) * maxrows); P->eq_code = malloc(sizeof(int) * maxrows);
    P->ineq_lb = malloc(sizeof(double) * maxrows); P->ineq_ub = malloc(sizeof(double) * maxrows);
    P->eq_val = malloc(sizeof(double) * maxrows);
  }
  int ni = 0, ne = 0, changed = 0;
  for (int k = 0; k <= N; k++)
  {
    int nu = P->nu[k];
    int o_i = ni, o_e = ne;
    int ngk = k < N ? NG : NGN;
    const double *lg = P->lbg + k * NG, *ug = P->ubg + k * NG;
    const int *gm = P->gmask + k * NG;
    for (int j = 0; j < ngk; j++)
    {
      if (!gm[j]) continue;
      if (isinf(lg[j]) && isinf(ug[j])) continue;
      P->ineq_code[ni] = j; P->ineq_lb[ni] = lg[j]; P->ineq_ub[ni] = ug[j]; ni++;
    }
    for (int j = 0; j < nu + NX; j++)
    {
      double lo = j < nu ? P->lbu[k * NUF + j] : P->lbx[k * NX + j - nu];
      double up = j < nu ? P->ubu[k * NUF + j] : P->ubx[k * NX + j - nu];
      if (lo == up) { P->eq_code[ne] = BND + j; P->eq_val[ne] = lo; ne++; }
      else if (!(isinf(lo) && isinf(up))) { P->ineq_code[ni] = BND + j; P->ineq_lb[ni] = lo; P->ineq_ub[ni] = up; ni++; }
    }
    if (P->solver && (P->n_ineq[k] != ni - o_i || P->n_eq[k] != ne - o_e)) changed = 1;
    P->ineq_off[k] = o_i; P->eq_off[k] = o_e;
    P->n_ineq[k] = ni - o_i; P->n_eq[k] = ne - o_e;
  }
  return changed;
}

/* ---------------------------------------------------------------- public API */
void *fp_create(int N, const int *b, int npg, const double *lbx, const double *ubx, const double *lbu,
                const double *ubu, const double *lbg, const double *ubg, const int *gmask, const double *Pk,
                const double *pg, const double *x0, const double *u0, int hess_exact)
{
  Prob *P = (Prob *)calloc(1, sizeof(Prob));
  P->N = N; P->K = N + 1; P->npg = npg; P->hess_exact = hess_exact;
  P->nu = (int *)malloc(sizeof(int) * (N + 1));
  for (int k = 0; k < N; k++) P->nu[k] = b[k] ? NUF : NUF - 1;
  P->nu[N] = 0;
  P->lbx = dup(lbx, sizeof(double) * (N + 1) * NX); P->ubx = dup(ubx, sizeof(double) * (N + 1) * NX);
  P->lbu = dup(lbu, sizeof(double) * N * NUF); P->ubu = dup(ubu, sizeof(double) * N * NUF);
  P->lbg = dup(lbg, sizeof(double) * (N * NG + NGN)); P->ubg = dup(ubg, sizeof(double) * (N * NG + NGN));
  P->gmask = dup(gmask, sizeof(int) * (N * NG + NGN));
  P->Pk = dup(Pk, sizeof(double) * NPK * (N + 1)); P->pg = dup(pg, sizeof(double) * npg);
  P->x0 = dup(x0, sizeof(double) * (N + 1) * NX); P->u0 = dup(u0, sizeof(double) * N * NUF);
  build_lists(P);
  /* casadi work */
  casadi_int sa, sr, si, sw, ma = 0, mr = 0, mi = 0, mw = 0;
#define WK(f) f##_work(&sa, &sr, &si, &sw); if (sa > ma) ma = sa; if (sr > mr) mr = sr; if (si > mi) mi = si; if (sw > mw) mw = sw;
  WK(fo_eval) WK(fo_jac) WK(fo_hess) WK(fo_hess_p) WK(fo_grad) WK(fo_teval) WK(fo_tjac) WK(fo_thess) WK(fo_thess_p)
  P->w = malloc(sizeof(double) * (mw + 1)); P->iw = malloc(sizeof(casadi_int) * (mi + 1));
  /* interface */
  struct FatropOcpCInterface *o = &P->ocp;
  memset(o, 0, sizeof(*o));
  o->get_nx = get_nx; o->get_nu = get_nu; o->get_ng = get_ng; o->get_ng_ineq = get_ng_ineq;
  o->get_horizon_length = get_K; o->get_bounds = get_bounds;
  o->get_initial_xk = get_x0; o->get_initial_uk = get_u0;
  o->full_eval_lag_hess = full_hess; o->full_eval_constr_jac = full_jac; o->full_eval_contr_viol = full_cv;
  o->full_eval_obj_grad = full_obj_grad; o->full_eval_obj = full_obj;
  o->user_data = P;
  P->solver = fatrop_ocp_c_create(o, cb_write, cb_flush);
  return P;
}


/* new data for the same structure; returns 0, or 1 if the row counts changed (recreate) */
int fp_update(void *p, const double *lbx, const double *ubx, const double *lbu, const double *ubu,
              const double *lbg, const double *ubg, const int *gmask, const double *Pk, const double *pg,
              const double *x0, const double *u0, int hess_exact)
{
  Prob *P = (Prob *)p;
  int N = P->N;
  memcpy(P->lbx, lbx, sizeof(double) * (N + 1) * NX); memcpy(P->ubx, ubx, sizeof(double) * (N + 1) * NX);
  memcpy(P->lbu, lbu, sizeof(double) * N * NUF); memcpy(P->ubu, ubu, sizeof(double) * N * NUF);
  memcpy(P->lbg, lbg, sizeof(double) * (N * NG + NGN)); memcpy(P->ubg, ubg, sizeof(double) * (N * NG + NGN));
  memcpy(P->gmask, gmask, sizeof(int) * (N * NG + NGN));
  memcpy(P->Pk, Pk, sizeof(double) * NPK * (N + 1)); memcpy(P->pg, pg, sizeof(double) * P->npg);
  memcpy(P->x0, x0, sizeof(double) * (N + 1) * NX); memcpy(P->u0, u0, sizeof(double) * N * NUF);
  P->hess_exact = hess_exact;
  return build_lists(P);
}

int fp_set_option(void *p, const char *name, double val)
{
  Prob *P = (Prob *)p;
  int t = fatrop_ocp_c_option_type(name);
  if (t == 0) return fatrop_ocp_c_set_option_double(P->solver, name, val);
  if (t == 1) return fatrop_ocp_c_set_option_int(P->solver, name, (int)val);
  if (t == 2) return fatrop_ocp_c_set_option_bool(P->solver, name, (int)val);
  return -100 + t;
}

void fp_set_initial(void *p, const double *x0, const double *u0)
{
  Prob *P = (Prob *)p;
  memcpy(P->x0, x0, sizeof(double) * (P->N + 1) * NX);
  memcpy(P->u0, u0, sizeof(double) * P->N * NUF);
}

/* the watchdog's wall-time budget of the next solves, in seconds from now (<= 0: none) */
void fp_set_deadline(void *p, double budget_s)
{
  Prob *P = (Prob *)p;
  P->deadline = budget_s > 0 ? cpu_now() + budget_s : 0.0;
}

int fp_nj(void) { return NJ; }

/* the compiled sizes: 0 NX, 1 NU, 2 NG, 3 NGN, 4 NPK */
int fp_dim(int which)
{
  const int d[5] = {NX, NU, NG, NGN, NPK};
  return which >= 0 && which < 5 ? d[which] : -1;
}

/* solve; writes X (N+1 x NX), U (N x NUF; 0 where unused), stats[0..13] */
int fp_solve(void *p, double *X, double *U, double *stats)
{
  Prob *P = (Prob *)p;
  memset(P->t_eval, 0, sizeof(P->t_eval));
  P->aborted = 0;
  double tc0 = cpu_now();
  int ret = fatrop_ocp_c_solve(P->solver);
  P->t_eval[4] = cpu_now() - tc0;
  const struct blasfeo_dvec *primal = fatrop_ocp_c_get_primal(P->solver);
  const struct FatropOcpCDims *s = fatrop_ocp_c_get_dims(P->solver);
  const double *pd = primal->pa;
  for (int k = 0; k <= P->N; k++)
  {
    memcpy(X + k * NX, pd + s->ux_offs[k] + s->nu[k], sizeof(double) * NX);
    if (k < P->N)
      for (int i = 0; i < NUF; i++) U[k * NUF + i] = i < s->nu[k] ? pd[s->ux_offs[k] + i] : 0.0;
  }
  const struct FatropOcpCStats *st = fatrop_ocp_c_get_stats(P->solver);
  stats[0] = st->iterations_count; stats[1] = st->time_total; stats[2] = st->compute_sd_time;
  stats[3] = st->eval_hess_time; stats[4] = st->eval_jac_time; stats[5] = st->eval_cv_time;
  stats[6] = st->eval_grad_time + st->eval_obj_time; stats[7] = st->return_flag;
  for (int i = 0; i < 5; i++) stats[8 + i] = P->t_eval[i];
  stats[13] = P->aborted;
  return ret;
}

void fp_free(void *p)
{
  Prob *P = (Prob *)p;
  if (!P) return;
  fatrop_ocp_c_destroy(P->solver);
  free(P->nu); free(P->lbx); free(P->ubx); free(P->lbu); free(P->ubu); free(P->lbg); free(P->ubg);
  free(P->gmask); free(P->Pk); free(P->pg); free(P->x0); free(P->u0);
  free(P->n_ineq); free(P->n_eq); free(P->ineq_off); free(P->eq_off); free(P->ineq_code); free(P->eq_code);
  free(P->ineq_lb); free(P->ineq_ub); free(P->eq_val); free(P->w); free(P->iw);
  free(P);
}
