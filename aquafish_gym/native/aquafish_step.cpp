/*
 * AquaFish compiled step: the simulator's per-step loop (fluid wrench, PyBullet force and
 * servo commands, stepSimulation, state read-back) in C, so that no Python runs between
 * physics steps. It is the same algorithm as aquafish_gym.simulator.BatchWorld.step with
 * aquafish_gym.fluid.box_drag / caudal_reactive_force / righting_torque in deep water and
 * aquafish_gym.surface.surface_wrench at the free surface, operation for operation in the
 * same order (tests compare the two bit for bit).
 *
 * How it reaches PyBullet: it is a PyBullet plugin. p.loadPlugin(path, "_aquafish") makes
 * the physics server call initPlugin_aquafish with a b3PhysicsClientHandle on that
 * server; the plugin keeps it, and Python (ctypes, same shared object) then calls
 * af_run() with the handle. The PyBullet C-API functions are looked up with dlsym in the
 * already-loaded pybullet extension module (af_bind), so the plugin links against nothing
 * and needs only the project's own declarations of PyBullet's C ABI (pybullet_abi.h).
 *
 * The code is plain C compiled as C++. Built by `pip install` (setup.py); rebuild in place
 * with python -m aquafish_gym.native.build.
 */
#include <dlfcn.h>

#include <cmath>
#include <cstddef>
#include <cstring>

#include "pybullet_abi.h" /* the project's own declarations of PyBullet's C ABI (no PyBullet headers needed) */

#define AF_VERSION 5 /* bump whenever af_run's signature or its arrays' layout change */
#define AF_API extern "C" __attribute__((visibility("default")))

/* ---- PyBullet C API, resolved at run time --------------------------------------------- */
typedef b3SharedMemoryStatusHandle (*fn_submit)(b3PhysicsClientHandle, b3SharedMemoryCommandHandle);
typedef int (*fn_status_type)(b3SharedMemoryStatusHandle);
typedef b3SharedMemoryCommandHandle (*fn_client_init)(b3PhysicsClientHandle);
typedef b3SharedMemoryCommandHandle (*fn_body_init)(b3PhysicsClientHandle, int);
typedef int (*fn_set_int)(b3SharedMemoryCommandHandle, int);
typedef int (*fn_actual2)(b3SharedMemoryStatusHandle, int*, int*, int*, int*, const double**, const double**,
                          const double**, const double**, const double**, const double**, const double**,
                          const double**);
typedef void (*fn_force)(b3SharedMemoryCommandHandle, int, int, const double*, const double*, int);
typedef void (*fn_torque)(b3SharedMemoryCommandHandle, int, int, const double*, int);
typedef b3SharedMemoryCommandHandle (*fn_joint_init)(b3PhysicsClientHandle, int, int);
typedef int (*fn_joint_set)(b3SharedMemoryCommandHandle, int, double);

static struct {
    int bound;
    fn_submit submit;
    fn_status_type status_type;
    fn_client_init step_init, force_init;
    fn_body_init state_init;
    fn_set_int state_link_velocity;
    fn_actual2 actual_state;
    fn_force apply_force;
    fn_torque apply_torque;
    fn_joint_init joint_init;
    fn_joint_set desired_position, desired_velocity, kp, kd, max_force;
} api;

static b3PhysicsClientHandle last_client = NULL;

/* Look the C API up in the pybullet module at `path` (already loaded). 0 on success, else
 * the 1-based index of the first missing symbol (-1: the library is not loaded). */
AF_API int af_bind(const char* path)
{
    void* lib = dlopen(path, RTLD_NOW | RTLD_NOLOAD);
    if (!lib) return -1;
    const char* names[] = {"b3SubmitClientCommandAndWaitStatus", "b3GetStatusType", "b3InitStepSimulationCommand",
                           "b3ApplyExternalForceCommandInit", "b3RequestActualStateCommandInit",
                           "b3RequestActualStateCommandComputeLinkVelocity", "b3GetStatusActualState2",
                           "b3ApplyExternalForce", "b3ApplyExternalTorque", "b3JointControlCommandInit2",
                           "b3JointControlSetDesiredPosition", "b3JointControlSetDesiredVelocity",
                           "b3JointControlSetKp", "b3JointControlSetKd", "b3JointControlSetMaximumForce"};
    void* found[15];
    for (int i = 0; i < 15; ++i) {
        found[i] = dlsym(lib, names[i]);
        if (!found[i]) return i + 1;
    }
    api.submit = (fn_submit)found[0];
    api.status_type = (fn_status_type)found[1];
    api.step_init = (fn_client_init)found[2];
    api.force_init = (fn_client_init)found[3];
    api.state_init = (fn_body_init)found[4];
    api.state_link_velocity = (fn_set_int)found[5];
    api.actual_state = (fn_actual2)found[6];
    api.apply_force = (fn_force)found[7];
    api.apply_torque = (fn_torque)found[8];
    api.joint_init = (fn_joint_init)found[9];
    api.desired_position = (fn_joint_set)found[10];
    api.desired_velocity = (fn_joint_set)found[11];
    api.kp = (fn_joint_set)found[12];
    api.kd = (fn_joint_set)found[13];
    api.max_force = (fn_joint_set)found[14];
    api.bound = 1;
    return 0;
}

AF_API int af_version(void) { return AF_VERSION; }

/* The PyBullet API version (pybullet.getAPIVersion()) that pybullet_abi.h describes. */
AF_API int af_pybullet_api_version(void) { return AF_PYBULLET_API_VERSION; }

/* The client handle of the server that loaded the plugin last (set by initPlugin). */
AF_API void* af_last_client(void) { return (void*)last_client; }

/* Forget the last client, so that af_last_client tells whether the next loadPlugin was fresh. */
AF_API void af_forget_last(void) { last_client = NULL; }

/* ---- plugin entry points ------------------------------------------------------------- */
AF_API int initPlugin_aquafish(struct b3PluginContext* context)
{
    last_client = context->m_physClient;
    return SHARED_MEMORY_MAGIC_NUMBER; /* the plugin manager checks it: built with this PyBullet's headers */
}

AF_API void exitPlugin_aquafish(struct b3PluginContext* context) { (void)context; }

AF_API int executePluginCommand_aquafish(struct b3PluginContext* context, const struct b3PluginArguments* arguments)
{
    (void)context;
    (void)arguments;
    return AF_VERSION;
}

/* ---- the model ----------------------------------------------------------------------- */
/* Rotation matrix of a unit quaternion (x, y, z, w): fluid.quat_to_matrix. */
static void quat_to_matrix(const double* q, double r[3][3])
{
    double x = q[0], y = q[1], z = q[2], w = q[3];
    double x2 = x + x, y2 = y + y, z2 = z + z;
    double xx = x * x2, yy = y * y2, zz = z * z2, xy = x * y2, xz = x * z2, yz = y * z2;
    double wx = w * x2, wy = w * y2, wz = w * z2;
    r[0][0] = 1 - (yy + zz); r[0][1] = xy - wz; r[0][2] = xz + wy;
    r[1][0] = xy + wz; r[1][1] = 1 - (xx + zz); r[1][2] = yz - wx;
    r[2][0] = xz - wy; r[2][1] = yz + wx; r[2][2] = 1 - (xx + yy);
}

/* (R^T a)_k = sum_i R[i][k] a[i], summed in numpy's order (i = 0, 1, 2). */
static double rt_dot(double r[3][3], int k, const double* a)
{
    return r[0][k] * a[0] + r[1][k] * a[1] + r[2][k] * a[2];
}

static void cross(const double* a, const double* b, double* out)
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

/* fluid.box_drag for one link: force (link frame) and, if torque != NULL, its torque. */
static void box_drag(double r[3][3], const double* v, const double* w, const double* offset, const double* areas,
                     double drag_c, int quadratic, const double* current, double* force, double* torque)
{
    double rel[3] = {v[0] - current[0], v[1] - current[1], v[2] - current[2]};
    double v_local[3], w_local[3], wxo[3];
    for (int k = 0; k < 3; ++k) {
        v_local[k] = rt_dot(r, k, rel);
        w_local[k] = rt_dot(r, k, w);
    }
    cross(w_local, offset, wxo);
    for (int k = 0; k < 3; ++k) {
        double u = v_local[k] + wxo[k];
        force[k] = quadratic ? drag_c * areas[k] * u * std::fabs(u) : drag_c * areas[k] * u;
    }
    if (torque) cross(offset, force, torque);
}

/* ---- the surface swimmer (aquafish_gym.surface, aquafish_gym.hydrostatics) ------------ */
static const double AF_TINY = 1e-12; /* hydrostatics.TINY */
static const double AF_PI = 3.141592653589793; /* math.pi */

static double clip_unit(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }

static double at_least(double x, double lo) { return x > lo ? x : lo; } /* np.maximum(x, lo) */

/* hydrostatics.acos_poly: Abramowitz & Stegun 4.4.46 */
static double acos_poly(double x)
{
    double a = std::fabs(x);
    double poly = 1.5707963050 + a * (-0.2145988016 + a * (0.0889789874 + a * (-0.0501743046 + a * (0.0308918810
                  + a * (-0.0170881256 + a * (0.0066700901 + a * -0.0012624911))))));
    double value = std::sqrt(1.0 - a) * poly;
    return x < 0 ? AF_PI - value : value;
}

/* hydrostatics.wetted_fraction */
static double wetted(double surface_z, double z, double half_height)
{
    return clip_unit((surface_z - z) / at_least(2.0 * half_height, AF_TINY) + 0.5, 0.0, 1.0);
}

static double half_height(double r[3][3], const double* half)
{
    return std::fabs(r[2][0]) * half[0] + std::fabs(r[2][1]) * half[1] + std::fabs(r[2][2]) * half[2];
}

static double drag1(double drag_c, int quadratic, double area, double u)
{
    return quadratic ? drag_c * area * u * std::fabs(u) : drag_c * area * u;
}

/* The constants of aquafish_gym.surface.SurfaceSpec, as NativeStep packs them. */
struct af_surface {
    const double* robot;   /* (n, AF_SURFACE_ROBOT): surface_z, weight, strip areas L/R (3+3), pectoral half L/R (3+3),
                              caudal half (3), hinge arm L/R (3+3), fin centre of mass L/R (3+3) */
    const double* strip_y; /* (n, 2, n_strips) */
    int n_strips;
    const double* slices;  /* (4, n_slices): y, rho, w, w*y */
    int n_slices;
    double pi_weight, rho_g, ballast;
};
#define AF_SURFACE_ROBOT 29

/* surface.surface_wrench for robot i: force[4][3] (link frames), torque[3] (body frame). */
static void surface_wrench(const struct af_surface* sf, int i, double rot[4][3][3], const double* pos,
                           const double* lin, const double* ang, const double* box_offset, const double* axis_areas,
                           double caudal_half, double caudal_mass, double drag_c, int quadratic, const double* current,
                           int reactive, double force[4][3], double torque[3])
{
    const double* rb = sf->robot + (size_t)AF_SURFACE_ROBOT * i;
    double surface_z = rb[0], weight = rb[1];
    double vl[4][3], wl[4][3];
    for (int l = 0; l < 4; ++l) {
        double rel[3] = {lin[3 * l] - current[0], lin[3 * l + 1] - current[1], lin[3 * l + 2] - current[2]};
        for (int k = 0; k < 3; ++k) {
            vl[l][k] = rt_dot(rot[l], k, rel);
            wl[l][k] = rt_dot(rot[l], k, ang + 3 * l);
        }
    }
    /* body: hydrostatics (hydrostatics.submerged_slices, hydrostatic_wrench) */
    double (*r0)[3] = rot[0];
    double a = r0[2][0], c = r0[2][1], b = r0[2][2];
    double norm = at_least(std::sqrt(a * a + b * b), AF_TINY);
    double top = surface_z - (pos[2] + b * sf->ballast);
    const double *ys = sf->slices, *rhos = sf->slices + sf->n_slices, *ws = sf->slices + 2 * sf->n_slices,
                 *wys = sf->slices + 3 * sf->n_slices;
    double volume = 0, along = 0, my = 0, wet_sum = 0;
    for (int k = 0; k < sf->n_slices; ++k) {
        double rho = rhos[k];
        double u = clip_unit((top - c * ys[k]) / (norm * rho), -1.0, 1.0);
        double root = std::sqrt(1.0 - u * u);
        double ac = acos_poly(u);
        double area = rho * rho * ((AF_PI - ac) + u * root);
        double lever = (-2.0 / 3.0) * rho * rho * rho * (root * root * root);
        double tv = ws[k] * area, tn = ws[k] * lever, ty = wys[k] * area, tw = ws[k] * (AF_PI - ac);
        if (k == 0) { volume = tv; along = tn; my = ty; wet_sum = tw; }
        else { volume += tv; along += tn; my += ty; wet_sum += tw; }
    }
    double wet = wet_sum / sf->pi_weight;
    double up[3] = {r0[2][0], r0[2][1], r0[2][2]};
    double buoyancy = sf->rho_g * volume;
    double safe = volume > 0 ? volume : 1.0;
    double moment[3] = {along * (a / norm), my, along * (b / norm)};
    double com[3] = {0.0, 0.0, -sf->ballast};
    double lever[3], f_b[3], t_hs[3], u[3], wxo[3], f_drag[3], t_drag[3];
    for (int k = 0; k < 3; ++k) {
        lever[k] = moment[k] / safe - com[k];
        f_b[k] = buoyancy * up[k];
    }
    cross(lever, f_b, t_hs);
    cross(wl[0], box_offset, wxo);
    for (int k = 0; k < 3; ++k) {
        u[k] = vl[0][k] + wxo[k];
        f_drag[k] = drag1(drag_c, quadratic, axis_areas[k] * wet, u[k]);
        force[0][k] = (buoyancy - weight) * up[k] + f_drag[k];
    }
    cross(box_offset, f_drag, t_drag);
    double couple[3] = {0.0, 0.0, 0.0}, push[3] = {0.0, 0.0, 0.0};
    /* pectorals: wetted blade-element strips; the body carries their force and moments */
    for (int f = 0; f < 2; ++f) {
        double (*r)[3] = rot[f + 1];
        const double* areas = rb + 2 + 3 * f;
        double e = half_height(r, rb + 8 + 3 * f);
        const double* sy = sf->strip_y + ((size_t)i * 2 + f) * sf->n_strips;
        double fx = 0, fy = 0, fz = 0, tx = 0, tz = 0;
        for (int j = 0; j < sf->n_strips; ++j) {
            double y = sy[j];
            double ux = vl[f + 1][0] - wl[f + 1][2] * y;
            double uz = vl[f + 1][2] + wl[f + 1][0] * y;
            double uy = vl[f + 1][1];
            double w = wetted(surface_z, pos[3 * (f + 1) + 2] + r[2][1] * y, e);
            double gx = drag1(drag_c, quadratic, areas[0] * w, ux);
            double gy = drag1(drag_c, quadratic, areas[1] * w, uy);
            double gz = drag1(drag_c, quadratic, areas[2] * w, uz);
            double hx = y * gz, hz = -(y * gx);
            if (j == 0) { fx = gx; fy = gy; fz = gz; tx = hx; tz = hz; }
            else { fx += gx; fy += gy; fz += gz; tx += hx; tz += hz; }
        }
        double fw[3];
        for (int k = 0; k < 3; ++k) fw[k] = r[k][0] * fx + r[k][1] * fy + r[k][2] * fz;
        const double *h = rb + 17 + 3 * f, *c = rb + 23 + 3 * f; /* hinge_arm, fin_com */
        double arm[3];
        for (int k = 0; k < 3; ++k)
            arm[k] = (r0[k][0] * h[0] + r0[k][1] * h[1] + r0[k][2] * h[2]) + (r[k][0] * c[0] + r[k][1] * c[1] + r[k][2] * c[2]);
        double mom[3] = {arm[1] * fw[2] - arm[2] * fw[1], arm[2] * fw[0] - arm[0] * fw[2],
                         arm[0] * fw[1] - arm[1] * fw[0]};
        for (int k = 0; k < 3; ++k) {
            couple[k] = couple[k] + ((r[k][0] * tx + r[k][2] * tz) + mom[k]);
            push[k] = push[k] + fw[k];
            force[f + 1][k] = 0.0;
        }
    }
    for (int k = 0; k < 3; ++k) force[0][k] = force[0][k] + rt_dot(r0, k, push);
    /* caudal fin: wetted drag and the reactive force of its wetted height */
    double (*r3)[3] = rot[3];
    double fin_wet = wetted(surface_z, pos[11], half_height(r3, rb + 14));
    for (int k = 0; k < 3; ++k) force[3][k] = drag1(drag_c, quadratic, axis_areas[9 + k] * fin_wet, vl[3][k]);
    if (reactive) {
        double wv = vl[3][0] + caudal_half * wl[3][2];
        double mw = caudal_mass * (fin_wet * fin_wet) * wv;
        double fx = -mw * vl[3][1];
        force[3][0] += fx;
        force[3][1] += 0.5 * mw * wv;
        double tzc = caudal_half * fx;
        for (int k = 0; k < 3; ++k) couple[k] = couple[k] + r3[k][2] * tzc;
    }
    for (int k = 0; k < 3; ++k) torque[k] = (t_hs[k] + t_drag[k]) + rt_dot(r0, k, couple);
}

/*
 * Run `steps` physics steps of n robots from the state in position .. angular_velocity
 * (as read after the last step or reset), leaving the new state there; see
 * aquafish_gym.native.NativeStep.run for the arrays' shapes. Returns 0 on success, or a
 * negative code: -1 not bound, -2 a state request failed, -3 an unexpected link count.
 * `currents` is (n, 3): each robot's own uniform water velocity (world frame).
 */
AF_API int af_run(void* client_handle, int n, int steps, const int* bodies, const int* active, const double* box_offsets,
           const double* axis_areas, const double* righting_w, const double* caudal_half, const double* caudal_mass,
           double drag_c, int quadratic, const double* currents, int reactive, int caudal_q,
           int caudal_u, double kp, double kd, double max_force, int n_osc, const int* osc_index,
           const double* caudal_angle, const double* caudal_velocity, double* position, double* orientation,
           double* linear_velocity, double* angular_velocity, double* body_quaternions,
           const double* surface_robot, const double* strip_y, int n_strips, const double* slices, int n_slices,
           double pi_weight, double rho_g, double ballast)
{
    struct af_surface sf = {surface_robot, strip_y, n_strips, slices, n_slices, pi_weight, rho_g, ballast};
    b3PhysicsClientHandle client = (b3PhysicsClientHandle)client_handle;
    static const double origin[3] = {0.0, 0.0, 0.0};
    if (!api.bound) return -1;
    for (int s = 0; s < steps; ++s) {
        {
            for (int i = 0; i < n; ++i) {
                double rot[4][3][3], force[4][3], torque[3];
                const int* act = active + 4 * i;
                const double* current = currents + 3 * i; /* robot i's water velocity (world frame) */
                for (int k = 0; k < 4; ++k) quat_to_matrix(orientation + 16 * i + 4 * k, rot[k]);
                if (surface_robot) { /* the surface swimmer: aquafish_gym.surface */
                    surface_wrench(&sf, i, rot, position + 12 * i, linear_velocity + 12 * i, angular_velocity + 12 * i,
                                   box_offsets + 12 * i, axis_areas + 12 * i, caudal_half[i], caudal_mass[i], drag_c,
                                   quadratic, current, reactive, force, torque);
                } else {
                for (int k = 0; k < 4; ++k)
                    box_drag(rot[k], linear_velocity + 12 * i + 3 * k, angular_velocity + 12 * i + 3 * k,
                             box_offsets + 12 * i + 3 * k, axis_areas + 12 * i + 3 * k, drag_c, quadratic, current,
                             force[k], k == 0 ? torque : NULL);
                /* fluid.righting_torque (world frame) */
                double righting[3] = {rot[0][1][2] * righting_w[i], -rot[0][0][2] * righting_w[i], 0.0};
                if (reactive) { /* fluid.caudal_reactive_force; its couple goes to the body */
                    const double* v3 = linear_velocity + 12 * i + 9;
                    const double* w3 = angular_velocity + 12 * i + 9;
                    double rel[3] = {v3[0] - current[0], v3[1] - current[1], v3[2] - current[2]};
                    double vx = rt_dot(rot[3], 0, rel), vy = rt_dot(rot[3], 1, rel), wz = rt_dot(rot[3], 2, w3);
                    double wv = vx + caudal_half[i] * wz;
                    double mw = caudal_mass[i] * wv;
                    double fx = -mw * vy, fy = 0.5 * mw * wv;
                    double tz = caudal_half[i] * fx;
                    force[3][0] += fx;
                    force[3][1] += fy;
                    force[3][2] += 0.0;
                    for (int k = 0; k < 3; ++k) righting[k] += rot[3][k][2] * tz;
                }
                for (int k = 0; k < 3; ++k)  /* world -> body frame */
                    torque[k] += rt_dot(rot[0], k, righting);
                }
                for (int k = 0; k < 4; ++k) {
                    if (!act[k]) continue;
                    b3SharedMemoryCommandHandle cmd = api.force_init(client);
                    api.apply_force(cmd, bodies[i], k - 1, force[k], origin, EF_LINK_FRAME);
                    api.submit(client, cmd);
                }
                b3SharedMemoryCommandHandle cmd = api.force_init(client);
                api.apply_torque(cmd, bodies[i], -1, torque, EF_LINK_FRAME);
                api.submit(client, cmd);
            }
            for (int j = 0; j < n_osc; ++j) { /* the caudal sweep, as BatchWorld.step */
                b3SharedMemoryCommandHandle cmd = api.joint_init(client, bodies[osc_index[j]], CONTROL_MODE_POSITION_VELOCITY_PD);
                api.desired_position(cmd, caudal_q, caudal_angle[(size_t)s * n_osc + j]);
                api.kp(cmd, caudal_u, kp);
                api.desired_velocity(cmd, caudal_u, caudal_velocity[(size_t)s * n_osc + j]);
                api.kd(cmd, caudal_u, kd);
                api.max_force(cmd, caudal_u, max_force);
                api.submit(client, cmd);
            }
            api.submit(client, api.step_init(client));
        }
        for (int i = 0; i < n; ++i) { /* read back every link's pose and velocity */
            b3SharedMemoryCommandHandle cmd = api.state_init(client, bodies[i]);
            api.state_link_velocity(cmd, 1);
            b3SharedMemoryStatusHandle status = api.submit(client, cmd);
            if (api.status_type(status) != CMD_ACTUAL_STATE_UPDATE_COMPLETED) return -2;
            int num_links = 0;
            const double *q = NULL, *qdot = NULL, *links = NULL, *link_velocities = NULL;
            api.actual_state(status, NULL, &num_links, NULL, NULL, NULL, &q, &qdot, NULL, NULL, NULL, &links,
                             &link_velocities);
            if (num_links != 3) return -3;
            double* pos = position + 12 * i;
            double* orn = orientation + 16 * i;
            double* lin = linear_velocity + 12 * i;
            double* ang = angular_velocity + 12 * i;
            std::memcpy(pos, q, 3 * sizeof(double));
            std::memcpy(orn, q + 3, 4 * sizeof(double));
            std::memcpy(lin, qdot, 3 * sizeof(double));
            std::memcpy(ang, qdot + 3, 3 * sizeof(double));
            for (int k = 0; k < 3; ++k) {
                std::memcpy(pos + 3 * (k + 1), links + 7 * k, 3 * sizeof(double));
                std::memcpy(orn + 4 * (k + 1), links + 7 * k + 3, 4 * sizeof(double));
                std::memcpy(lin + 3 * (k + 1), link_velocities + 6 * k, 3 * sizeof(double));
                std::memcpy(ang + 3 * (k + 1), link_velocities + 6 * k + 3, 3 * sizeof(double));
            }
            if (body_quaternions) std::memcpy(body_quaternions + ((size_t)i * steps + s) * 4, orn, 4 * sizeof(double));
        }
    }
    return 0;
}
