/*
 * The part of PyBullet's C ABI that aquafish_step.cpp relies on, declared by this project
 * so that the plugin builds with nothing but a C++ compiler (no PyBullet source, no
 * download).
 *
 * These are facts about the pybullet extension module's exported interface, written down
 * here in our own words. They were checked against the public headers of the PyBullet
 * 3.2.6 and 3.2.7 source distributions (examples/SharedMemory/SharedMemoryPublic.h,
 * PhysicsClientC_API.h, plugins/b3PluginContext.h), which are identical in both releases
 * for everything below: the API version (SHARED_MEMORY_MAGIC_NUMBER) is 202010061 in both.
 *
 * Supported range: pybullet >= 3.2.6, < 3.3 (AF_PYBULLET_MIN / AF_PYBULLET_BELOW; the same
 * pin as pyproject.toml and aquafish_gym.native.PYBULLET_RANGE). Two guards keep another
 * release out:
 *   - aquafish_gym.native refuses a pybullet outside the range, and one whose
 *     pybullet.getAPIVersion() differs from AF_PYBULLET_API_VERSION (af_pybullet_api_version);
 *   - initPlugin_aquafish returns AF_PYBULLET_API_VERSION, and PyBullet's plugin manager
 *     refuses a plugin whose number differs from its own.
 * To support a new release: compare its headers with the values below, update them and the
 * range here, in pyproject.toml and in aquafish_gym/native/__init__.py.
 */
#ifndef AQUAFISH_PYBULLET_ABI_H
#define AQUAFISH_PYBULLET_ABI_H

#define AF_PYBULLET_MIN "3.2.6"   /* oldest release checked */
#define AF_PYBULLET_BELOW "3.3"   /* first release not supported */

/* PyBullet's API version: pybullet.getAPIVersion(), and what a plugin's init must return. */
#define AF_PYBULLET_API_VERSION 202010061
#define SHARED_MEMORY_MAGIC_NUMBER AF_PYBULLET_API_VERSION

/* Opaque handles: PyBullet passes pointers to structures the plugin never looks into. */
typedef struct b3PhysicsClientHandle__ { int unused; }* b3PhysicsClientHandle;
typedef struct b3SharedMemoryCommandHandle__ { int unused; }* b3SharedMemoryCommandHandle;
typedef struct b3SharedMemoryStatusHandle__ { int unused; }* b3SharedMemoryStatusHandle;

/* The constants the step passes or compares (PyBullet's enum values). */
enum {
    EF_LINK_FRAME = 1,                      /* b3ApplyExternalForce/Torque: vectors in the link frame */
    CONTROL_MODE_POSITION_VELOCITY_PD = 2,  /* b3JointControlCommandInit2: the servo mode of setJointMotorControl2 */
    CMD_ACTUAL_STATE_UPDATE_COMPLETED = 21  /* b3GetStatusType after a b3RequestActualStateCommandInit */
};

/* What PyBullet hands a plugin's entry points. The plugin only reads the first member, the
 * client handle on the server that loads it; PyBullet's structure has more members after it
 * (user pointer, return data, input events), which the plugin never touches, so they are not
 * declared. PyBullet allocates the structure: never create or copy one here. */
struct b3PluginContext {
    b3PhysicsClientHandle m_physClient;
};

/* Passed to executePluginCommand; used only as a pointer. */
struct b3PluginArguments;

#endif /* AQUAFISH_PYBULLET_ABI_H */
