/*
 * The public entry points of the force fields: model checks, hx_field (the memoryless field
 * and its Jacobian) and hx_tick_force (a servo tick's force with its state). The fields
 * themselves are in hx_fields.h, each one function written over [x, y, z] with its analytic
 * Jacobian, dispatched through one table (no chain of ifs on the letter).
 *
 * Notation: s = grad h = (h_x, h_y), H its Hessian, g = (1 + |s|^2)^(-1/2), the unit normal
 * of the textured surface n = (-s, 1) g, P = I - g^2 s s^T (d(g s)/dx = g P H), d = p^z - h
 * the vertical penetration (< 0 inside, Table I), and d_l = max(d, -d^z_max) the lateral
 * depth of Remark 3 ("follows" where d_l = d, so that its derivative is that of d).
 * Over a profile s_y = 0 and H = [[h'', 0], [0, 0]], and every formula below reduces exactly
 * to the paper's 2-D one (the tests check both against the NumPy fields).
 */
#include "hx_core.h"
#include "hx_fields.h"

#include <math.h>
#include <stddef.h>

int hx_model_check(const hx_model *m) { return hx__model_check(m, 0); }

int hx__model_check(const hx_model *m, int texture_checked)
{
    int rc;
    if (m->code < 0 || m->code >= HX_N_ALGS)
        return HX_BAD_ALGORITHM;
#ifdef HX_ONLY_ALG /* an export for one letter (hx_fields.h) */
    if (m->code != HX_ONLY_ALG)
        return HX_NOT_IN_CORE;
#endif
    rc = texture_checked ? HX_OK : hx_texture_check(m->tex.kind, m->tex.c, m->tex.rows, m->tex.cols);
#if !defined(HX_ONLY_ALG) || HX_ONLY_ALG == 6
    if (rc == HX_OK && m->code == HX_ALG_F) {
        if (!(m->prm[HX_P_DXMAX] > 0.0) || !isfinite(m->prm[HX_P_DXMAX]))
            return HX_BAD_COEFFS;
        if (m->prm[HX_P_ZSTICK] >= 0.0)
            rc = hx_presliding_table_check(m->aux, m->naux);
    }
#endif
    if (rc == HX_OK && m->code == HX_ALG_PROXY && !(m->prm[HX_P_DXMAX] > 0.0 && isfinite(m->prm[HX_P_DXMAX])))
        return HX_BAD_COEFFS; /* the proxy's longest step */
    if (rc == HX_OK && m->base != NULL) { /* on an object: A, B, C, F, G, the proxy; D and E but on a faceted mesh */
#ifdef HX_NO_OBJECTS /* an export on the plane (haptex export): the objects' code is not linked */
        return HX_NOT_IN_CORE;
#else
        rc = hx_base_check(m->base);
        if (rc == HX_OK && !hx__on_base(m->code, m->base))
            rc = HX_NOT_IN_CORE;
        if (rc == HX_OK && (m->code == HX_ALG_D || m->code == HX_ALG_E)) /* a surface's search constants */
            rc = (m->tex.kind == HX_SURFACE_GRATINGS || m->tex.kind == HX_SURFACE_PATCHES)
                     ? hx_surface_aux_check(m->aux, m->naux) : HX_BAD_COEFFS;
        return rc;
#endif
    }
#if !defined(HX_ONLY_ALG) || HX_ONLY_ALG == 4 || HX_ONLY_ALG == 5
    if (rc == HX_OK && (m->code == HX_ALG_D || m->code == HX_ALG_E)) {
        if (m->tex.kind == HX_SURFACE_GRATINGS || m->tex.kind == HX_SURFACE_PATCHES)
            rc = hx_surface_aux_check(m->aux, m->naux);
        else
            rc = hx_closest_aux_check(m->aux, m->naux);
    }
#endif
    return rc;
}

int hx_field(const hx_model *m, const double p[3], double f[3], double jac[9])
{
    field_fn fn;
    field_out o = {0.0, NAN};
    zero(f, jac);
    if (m->code < 0 || m->code >= HX_N_ALGS)
        return HX_BAD_ALGORITHM;
    fn = FIELDS[m->code];
    if (fn == NULL)
        return HX_NOT_IN_CORE;
    fn(m, p, f, jac, &o);
    return HX_OK;
}

int hx_tick_force(const hx_model *m, hx_state *s, const double p[3], double f[3])
{
    if (m->base != NULL)
#ifdef HX_NO_OBJECTS
        return HX_NOT_IN_CORE;
#else
        return hx_object_force(m, s, p, f);
#endif
    return hx__tick_force(m, s, p, f);
}
