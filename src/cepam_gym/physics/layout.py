"""Column layout of the flat parameter vector the compiled kernels read.

:meth:`cepam_gym.plant.params.PlantParams.to_array` fills one row per plant (derived quantities such as
braid thread lengths already computed), so the hot loop only indexes. The indices are module
constants because numba freezes module globals at compile time.
"""

# --- muscle geometry and force model (paper Eq. 1-45) ---
BC = 0  # CPAM thread length b_c [m] (Eq. 8)
NC = 1  # CPAM turns n_c [-] (Eq. 9)
BE = 2  # EPAM thread length b_e [m] (Eq. 11)
NE = 3  # EPAM turns n_e [-] (Eq. 12)
TA = 4  # effective wall thickness t_a = t_s + t_b [m] (Eq. 35); 0 below the "enhanced" level
RADIAL = 5  # 1.0 if the radial-expansion pressure P_r (Eq. 26-33) is applied, else 0.0
DOC = 6  # CPAM bladder diameter D_oc [m] (Eq. 32)
DOE = 7  # EPAM bladder diameter D_oe [m] (Eq. 28)
KR_LO = 8  # K_r when D sin(theta) > D_o / 2 [Pa/m] (Eq. 27)
KR_HI = 9  # K_r when D sin(theta) < D_o / 2 [Pa/m] (Eq. 27)
KAPPA = 10  # factor on P_e dV_c/dL: 1.3 in the paper (Eq. 22), 1 by virtual work
LAMBDA = 11  # factor on P_e dV_ac/dL: 1 in the paper (Eq. 15), 0 by virtual work
K_EL = 12  # bladder elasticity [N/m] (not in the paper; calibrated default)
L_EL0 = 13  # rest length of that elasticity [m]
L_MIN = 14  # lower end stop [m]
L_MAX = 15  # upper end stop [m]
# --- air supply and valves ---
P_ATM = 16  # atmosphere [Pa abs]
P_SUP = 17  # supply [Pa abs]
T_SUP = 18  # supply temperature [K]
T_AMB = 19  # ambient / wall temperature [K]
C_PROP = 20  # proportional valve sonic conductance, fully open [m^3/(s Pa)]
B_CRIT = 21  # ISO 6358 critical pressure ratio b [-]
R_LAM = 22  # pressure ratio above which the flow is linearised (laminar) [-]
C_LEAK = 23  # leakage conductance of each chamber to atmosphere [m^3/(s Pa)]
TAU_SPOOL = 24  # spool time constant [s]
SPOOL_ORDER = 25  # 1 or 2
ZETA = 26  # spool damping ratio (order 2)
C_ONOFF = 27  # on/off valve sonic conductance [m^3/(s Pa)]
TAU_SWITCH = 28  # on/off valve switching lag [s]
PWM_PERIOD = 29  # PWM period [s]
VD_C = 30  # dead volume of the CPAM port and tubing [m^3]
VD_E = 31  # dead volume of the EPAM port and tubing [m^3]
HA = 32  # wall heat transfer coefficient times area, each chamber [W/K]
P_BURST = 33  # bladder burst pressure [Pa gauge]
N_POLY = 34  # polytropic exponent of the closed-chamber stiffness [-]
# --- load mechanics ---
M_END = 35  # moving mass of the free end cap [kg]
DAMP = 36  # viscous damping [N s/m]
F_COUL = 37  # Coulomb friction [N]
GRAV = 38  # gravitational acceleration [m/s^2]
# --- pressure set-point mode ---
REG_GAIN = 39  # gain of the in-plant pressure regulator [1/Pa]: spool = gain * (p_set - p)
# --- derived constants (filled by PlantParams.to_array): reciprocals and square roots computed
# once per plant instead of once per sub-step; never set them by hand
INV_BC = 40  # 1 / b_c
INV_BE = 41  # 1 / b_e
QC = 42  # 1 / (4 pi n_c^2)
QE = 43  # 1 / (4 pi n_e^2)
TBN_C = 44  # t_a b_c / n_c
TBN_E = 45  # t_a b_e / n_e
TAN_C = 46  # t_a / n_c
TAN_E = 47  # t_a / n_e
DK_C = 48  # b_c / (pi n_c)
DK_E = 49  # b_e / (pi n_e)
PTA2 = 50  # pi t_a^2
INV_PNB_C = 51  # 1 / (pi n_c b_c)
INV_PNB_E = 52  # 1 / (pi n_e b_e)
INV_1MB = 53  # 1 / (1 - b)
LAM_K = 54  # sqrt(1 - x_lam^2) / (1 - r_lam), x_lam = (r_lam - b) / (1 - b): laminar slope factor
K_SUP = 55  # sqrt(T0 / T_supply)
K_AMB = 56  # sqrt(T0 / T_ambient)
# --- plant v1 statics (docs/physics.md "Plant v1"); zero in a v0 row, which leaves v0 unchanged ---
SLACK_W = (
    57  # tension-only braids: width [Pa] of the CPAM braid's slack switch; 0 = the braid also pushes (v0)
)
MU_B = 58  # bladder shear modulus mu [Pa] of the neo-Hookean wall; 0 = no bladder energy (v0)
TB_EL = 59  # bladder wall thickness of the strain energy [m] (t_b, Eq. 35)
LREF_C = 60  # CPAM bladder's stress-free length [m] (its rest length, section II)
LREF_E = 61  # EPAM bladder's stress-free length [m] (15 cm, section III)
# derived by fill_derived
EL_C = 62  # mu * rubber volume of the CPAM bladder [J] (pi (D_oc - t_b) t_b L_ref,c)
EL_E = 63  # mu * rubber volume of the EPAM bladder [J]
INV_LREF_C = 64  # 1 / L_ref,c
INV_LREF_E = 65  # 1 / L_ref,e
INV_DREF_C = 66  # 1 / braid diameter at L_ref,c
INV_DREF_E = 67  # 1 / braid diameter at L_ref,e
# --- plant v1 air and valves; zero in a v0 row ---
H_WALL = 68  # wall heat transfer coefficient h [W/(m^2 K)]; 0 = one hA for both chambers (v0, HA)
D_ON = 69  # on/off valve opening dead time [s]
D_OFF = 70  # on/off valve closing dead time [s]
HA_C = 71  # hA of the CPAM chamber [W/K] (derived: HA in v0, h times its wall area in v1)
HA_E = 72  # hA of the annulus [W/K] (derived)
# --- plant v1 braid-bladder friction (Maxwell-slip); zero in a v0 row ---
FR_C = 73  # break-away force per Pa of (Pc+ + Pe+) [N/Pa]; 0 = no friction (v0)
FR_D = 74  # presliding displacement of the slowest element [m]
# --- plant v2 (docs/physics.md "Plant v2"); zero in a v0 or v1 row, which leaves those unchanged ---
COL_A = 75  # seal area of a slack, collapsed CPAM on the end cap [m^2]: (Pe - Pc)+ pulls on it; 0 = v1
FR_MU = 76  # friction coefficient of the contact-area law [-]; 0 = the v1 law FR_C (Pc+ + Pe+)
FR_CC = 77  # derived (contact-area law): break-away force per Pa of Pc+ [N/Pa]; FR_C is then per Pa of Pe+
THR_E = 78  # EPAM braid thread compliance [1/N]: strain per N of total thread tension; 0 = inextensible
THR_AE = 79  # derived: THR_E b_e / (2 pi n_e^2) [1/(Pa m)]: the thread is b_e / (1 - THR_AE P_ae L)
THR_C = 80  # CPAM braid thread compliance [1/N]; 0 = inextensible
THR_AC = 81  # derived: THR_C b_c / (2 pi n_c^2): the CPAM's thread is b_c / (1 - THR_AC (P_ac - P_ae) L)
# --- plant option (docs/physics.md "PWM timing"); zero in every released preset ---
# 1.0: on/off valves switch at their exact PWM edges and dead times inside a sub-step; 0: once per sub-step
PWM_EXACT = 82

N_PARAMS = 83

NAMES = tuple(
    name
    for name, value in sorted(
        ((k, v) for k, v in dict(globals()).items() if k.isupper() and isinstance(v, int)),
        key=lambda kv: kv[1],
    )
    if name != "N_PARAMS"
)
assert len(NAMES) == N_PARAMS, "parameter layout indices must be 0..N_PARAMS-1 without gaps"

# Gas constants of air (not randomised)
R_AIR = 287.0  # J/(kg K)
GAMMA = 1.4
CV = R_AIR / (GAMMA - 1.0)  # J/(kg K)
CP = GAMMA * CV
RHO0 = 1.185  # ISO 6358 reference density [kg/m^3]
T0 = 293.15  # ISO 6358 reference temperature [K]
