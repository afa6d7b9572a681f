// tri_core: the ray-triangle test unit of the fixed-point device, fully pipelined, one triangle per clock. It
// computes exactly hw::triangle_test (hwmodel/datapath/intersect_fixed.h) on grid vertices v0, v1, v2 and a FixedRay's
// origin o (grid.F) and direction d (D fraction bits), with t = hw::div_shift(num, den, S, kNearestEven,
// 2^TB - 1) and hw::in_register, and hands out the three integers the caller needs for u and v:
//   A_i = (v_i << F) - o                                     (translated vertices, grid.F)
//   e0 = d . (A1 x A2),  e1 = d . (A2 x A0),  e2 = d . (A0 x A1)   (edge functions, exact integers)
//   det = e0 + e1 + e2;  a hit needs no two e_i of strictly opposite signs and det != 0
//   N = (v1 - v0) x (v2 - v0) (grid normal),  num = N . A0,  den = N . d = det / 2^(2F) (exact)
//   t = round-to-nearest-even(num * 2^S / den) as div_shift computes it (below), saturated to +-(2^TB - 1)
//   hit = signs ok && det != 0 && tmin <= t <= tlim && -(2^TB - 1) < t < 2^TB - 1
// Outputs per triangle: hit, t, e1, e2, det (u = e1 / det, v = e2 / det are formed in float outside the
// datapath, as the C++ does with doubles). t, e1, e2 and det are output for every triangle, hit or not: t is the
// rounded quotient whenever den != 0 (meaningless when den = 0), and e1, e2, det are always the exact integers.
//
// Edge functions. The C++ definition is d . (p x q) in 128-bit integers (the "general path"); its 64-bit short
// path uses the triple product d . (p x q) = p . (q x d). Both are exact, so they give the same integers; the
// unit uses the triple-product form at full width (m = A2 x d serves e0 = A1 . m and e1 = -A0 . m, n = A1 x d
// serves e2 = A0 . n): 6 + 6 narrow products and 9 wide ones instead of 18 + 9, and no magnitude test.
// den from det: sum e_i = d . ((A1 - A0) x (A2 - A0)) = 2^(2F) d . N exactly, so den = det >>> 2F (no products).
//
// Division (div_shift_wide): with den' = |den| and num' = num * sign(den), Q = floor(num' 2^S / den') and
// R = num' 2^S - Q den' (0 <= R < den'); q = Q >> S saturates to +limit when q >= qmax and to -limit when
// q < -qmax (qmax = (limit >> S) + 1); else t = Q + round, round = 2R > den' or (2R == den' and S > 0 and Q odd),
// clamped to +-limit. The unit divides magnitudes, |num| 2^S / |den|, with a restoring divider of QWP quotient
// bits (QWP >= QW = S + log2(qmax) + 1, enough that a larger quotient saturates), and fixes the sign after:
// Q = -Qu - (Ru != 0), R = Ru != 0 ? den' - Ru : 0 when num and den differ in sign.
//
// Widths (parameters; rtl_sim/params/tri_params.h derives them from a FixedFormat; signed values carry one sign
// bit more than their magnitude bits):
//   v            B bits unsigned per coordinate (the grid [0, 2^B - 1])
//   o            A bits signed, |o| < 2^(A-1) = 2^(B+G+F) (the frame's guard range), A = B+G+F+1
//   d            D+2 bits signed, |d| <= 2^D
//   A_i          A+1 bits signed (|A| < 2^A, FixedFormat::translated_bits)
//   A x d        A+D+2 bits signed; e0, e1, e2, det: EW = 2A+D+4 bits signed (edge_function_bits + 1)
//   v1-v0, N     B+1 and 2B+2 bits signed;  num: 2B+A+4 bits signed;  den: 2B+D+4 bits signed
//   divider      remainder 2B+D+3 bits (|den|), QWP quotient bits, QWP = DS * BPS (below)
//   tmin, tlim, t  TB+1 bits signed, |t| <= 2^TB - 1 (TB = t_bits)
// Contract: vertices on the grid, |o| < 2^(A-1), |d| <= 2^D, |tmin|, |tlim| <= 2^TB - 1 (what ray setup and a
// valid image give). Per-coordinate fields are packed flat: vertex i, axis a of a W-bit field at
// [(3*i+a)*W +: W], axis a of o or d at [a*W +: W].
//
// Pipeline: LATENCY = 5 + DS stages (LATENCY >= 6), each followed by one register:
//   1 translate: A_i = (v_i << F) - o (9 subtractions), grid edges v1 - v0, v2 - v0
//   2 cross: m = A2 x d, n = A1 x d (12 (A+1) x (D+2) products), N = (v1-v0) x (v2-v0) (6 (B+1)^2 products)
//   3 dot: e0, e1, e2 (9 (A+1) x (A+D+2) products), num = N . A0 (3 (2B+2) x (A+1) products)
//   4 decide: det, sign tests, den = det >>> 2F, |num|, |den|, quotient sign, overflow test of the division
//   5 .. 4+DS divide: DS stages of BPS = ceil(QW / DS) restoring steps each (one quotient bit per step: with
//     LATENCY = 5 + QW one bit per stage)
//   LATENCY finish: sign of the quotient, rounding, saturation, [tmin, tlim] and in-register tests
// (rdna2: LATENCY = tri_latency = 12, QW = 57: DS = 7 stages of 9 bits; embedded: 10, QW = 33: 5 of 7.)
//
// Handshake (valid/ready, as box_core.sv): an input is taken at a rising edge with in_valid && in_ready, a result
// leaves at a rising edge with out_valid && out_ready; while out_valid && !out_ready the outputs hold. Every
// stage has a valid bit and loads when it is empty or its successor loads (a stall holds every item in place,
// bubbles are squeezed out): in_ready = out_ready || some stage is empty; the only combinational path from the
// output side to the input side is out_ready -> in_ready.
//
// Latency and throughput: a triangle taken at edge c leaves at edge c + LATENCY when out_ready is high; with
// out_ready high in_ready stays high, one triangle test per clock. This is the timing model's triangle unit
// with tri_rate = 1 and tri_latency = LATENCY (hwmodel/timing/timing_config.h).
module tri_core #(
    parameter int B       = 24,  // grid bits of a vertex coordinate (coord_bits)
    parameter int A       = 39,  // translated magnitude bits B+G+F+1 (the origin port is A bits signed)
    parameter int F       = 8,   // fraction bits of the origin (frac_bits)
    parameter int D       = 24,  // fraction bits of the direction (dir_bits)
    parameter int TB      = 56,  // t magnitude bits (t_bits): t saturates at +-(2^TB - 1)
    parameter int S       = 32,  // t_shift D - F + T: quotient scale
    parameter int TAGW    = 16,  // user tag carried with each triangle
    parameter int LATENCY = 12,  // pipeline depth in clocks (>= 6)
    localparam int DW     = D + 2,          // direction, signed
    localparam int EW     = 2 * A + D + 4   // edge functions and det, signed
) (
    input logic clk,
    input logic rst,  // synchronous, active high: empties the pipeline

    input  logic            in_valid,
    output logic            in_ready,
    input  logic [TAGW-1:0] in_tag,
    input  logic [ 9*B-1:0] in_v,     // vertex i, axis a at [(3*i+a)*B +: B], unsigned
    input  logic [ 3*A-1:0] in_o,     // origin, grid.F, signed, axis a at [a*A +: A]
    input  logic [3*DW-1:0] in_d,     // direction, D fraction bits, signed
    input  logic [    TB:0] in_tmin,  // signed
    input  logic [    TB:0] in_tlim,  // signed: the current closest hit (or tmax)

    output logic            out_valid,
    input  logic            out_ready,
    output logic [TAGW-1:0] out_tag,
    output logic            out_hit,
    output logic [    TB:0] out_t,    // signed, |t| <= 2^TB - 1
    output logic [  EW-1:0] out_e1,   // signed
    output logic [  EW-1:0] out_e2,   // signed
    output logic [  EW-1:0] out_det   // signed
);
  localparam int AW = A + 1;  // translated vertex
  localparam int GW = B + 1;  // grid edge
  localparam int MW = A + D + 2;  // A x d component
  localparam int NW = 2 * B + 2;  // normal component
  localparam int NUMW = 2 * B + A + 4;  // num, signed
  localparam int DENM = 2 * B + D + 3;  // |den| bits
  localparam int DS = LATENCY - 5;  // divider stages
  localparam int QW = TB > S ? TB + 1 : S + 1;  // quotient bits needed before saturation
  localparam int BPS = DS > 0 ? (QW + DS - 1) / DS : 1;  // quotient bits per divider stage
  localparam int QWP = BPS * (DS > 0 ? DS : 1);  // quotient bits computed
  localparam int XT = (NUMW - 1 + S > QWP ? NUMW - 1 + S : QWP) + 1;  // |num| << S, with room for the >> QWP
  localparam int QSW = QWP + 2;  // signed quotient
  localparam int TW = TB + 1;  // t, signed
  localparam logic signed [QSW-1:0] QHI = TB > S ? QSW'(1) << TB : QSW'(1) << S;  // qmax << S
  localparam logic signed [QSW-1:0] QLIM = (QSW'(1) << TB) - QSW'(1);  // limit = 2^TB - 1
  localparam logic signed [TW-1:0] TLIM = (TW'(1) << TB) - TW'(1);

  initial begin
    if (LATENCY < 6) $error("tri_core: LATENCY must be >= 6 (4 stages, one divider stage, finish)");
  end

  // ---- handshake: valid bit per stage, load enables (as box_core) -----------------------------------------
  logic [LATENCY:1] vs;
  logic [LATENCY:0] vin;
  logic [LATENCY:1] en;
  logic [LATENCY:1] ld;
  assign vin = {vs, in_valid};
  for (genvar s = 1; s <= LATENCY; s++) begin : g_en
    assign en[s] = out_ready | ~(&vs[LATENCY:s]);
    assign ld[s] = en[s] & vin[s-1];
  end
  always_ff @(posedge clk) begin
    if (rst) vs <= '0;
    else for (int s = 1; s <= LATENCY; s++) if (en[s]) vs[s] <= vin[s-1];
  end
  assign in_ready  = en[1];
  assign out_valid = vs[LATENCY];

  // ---- step 1: translate ------------------------------------------------------------------------------------
  logic [9*AW-1:0] s1_a;  // A_i axis a at (3*i+a)*AW
  logic [6*GW-1:0] s1_g;  // v1 - v0 at a*GW, v2 - v0 at (3+a)*GW
  for (genvar i = 0; i < 3; i++) begin : g_tr
    for (genvar a = 0; a < 3; a++) begin : g_axis
      logic [AW-1:0] vf;  // v << F < 2^(B+F) <= 2^(A-1)
      assign vf = AW'(in_v[(3*i+a)*B+:B]) << F;
      assign s1_a[(3*i+a)*AW+:AW] = $signed(vf) - $signed(AW'($signed(in_o[a*A+:A])));
    end
  end
  for (genvar a = 0; a < 3; a++) begin : g_edge
    assign s1_g[a*GW+:GW] = GW'(in_v[(3+a)*B+:B]) - GW'(in_v[a*B+:B]);
    assign s1_g[(3+a)*GW+:GW] = GW'(in_v[(6+a)*B+:B]) - GW'(in_v[a*B+:B]);
  end
  localparam int W1 = 9 * AW + 6 * GW + 3 * DW + 2 * TW + TAGW;
  logic [W1-1:0] r1;
  always_ff @(posedge clk) if (ld[1]) r1 <= {s1_a, s1_g, in_d, in_tmin, in_tlim, in_tag};

  // ---- step 2: cross products -----------------------------------------------------------------------------
  logic [9*AW-1:0] s2_a;
  logic [6*GW-1:0] s2_g;
  logic [3*DW-1:0] s2_d;
  logic [TW-1:0] s2_tmin, s2_tlim;
  logic [TAGW-1:0] s2_tag;
  assign {s2_a, s2_g, s2_d, s2_tmin, s2_tlim, s2_tag} = r1;

  // Products are exact modulo 2^MW (resp. 2^NW) and the differences fit, so each is computed at that width.
  logic [3*MW-1:0] s2_m, s2_n;  // A2 x d, A1 x d
  logic [3*NW-1:0] s2_nrm;  // (v1 - v0) x (v2 - v0)
  for (genvar k = 0; k < 3; k++) begin : g_cross
    localparam int K1 = (k + 1) % 3, K2 = (k + 2) % 3;
    for (genvar i = 1; i < 3; i++) begin : g_vec  // A_i x d: i = 2 gives m, i = 1 gives n
      logic signed [MW-1:0] c;
      assign c = $signed(MW'($signed(s2_a[(3*i+K1)*AW+:AW]))) * $signed(MW'($signed(s2_d[K2*DW+:DW]))) -
          $signed(MW'($signed(s2_a[(3*i+K2)*AW+:AW]))) * $signed(MW'($signed(s2_d[K1*DW+:DW])));
      if (i == 2) begin : g_m
        assign s2_m[k*MW+:MW] = c;
      end else begin : g_n
        assign s2_n[k*MW+:MW] = c;
      end
    end
    assign s2_nrm[k*NW+:NW] =
        $signed(NW'($signed(s2_g[K1*GW+:GW]))) * $signed(NW'($signed(s2_g[(3+K2)*GW+:GW]))) -
        $signed(NW'($signed(s2_g[K2*GW+:GW]))) * $signed(NW'($signed(s2_g[(3+K1)*GW+:GW])));
  end
  localparam int W2 = 6 * AW + 6 * MW + 3 * NW + 2 * TW + TAGW;
  logic [W2-1:0] r2;
  always_ff @(posedge clk) if (ld[2]) r2 <= {s2_a[0+:6*AW], s2_m, s2_n, s2_nrm, s2_tmin, s2_tlim, s2_tag};

  // ---- step 3: dot products ---------------------------------------------------------------------------------
  logic [3*AW-1:0] s3_a0, s3_a1;
  logic [3*MW-1:0] s3_m, s3_n;
  logic [3*NW-1:0] s3_nrm;
  logic [TW-1:0] s3_tmin, s3_tlim;
  logic [TAGW-1:0] s3_tag;
  assign {s3_a1, s3_a0, s3_m, s3_n, s3_nrm, s3_tmin, s3_tlim, s3_tag} = r2;

  logic signed [EW-1:0] s3_e0, s3_e1, s3_e2, s3_p1m, s3_p0m, s3_p0n;
  logic signed [NUMW-1:0] s3_num;
  always_comb begin
    s3_p1m = '0;
    s3_p0m = '0;
    s3_p0n = '0;
    s3_num = '0;
    for (int k = 0; k < 3; k++) begin
      s3_p1m = s3_p1m + $signed(EW'($signed(s3_a1[k*AW+:AW]))) * $signed(EW'($signed(s3_m[k*MW+:MW])));
      s3_p0m = s3_p0m + $signed(EW'($signed(s3_a0[k*AW+:AW]))) * $signed(EW'($signed(s3_m[k*MW+:MW])));
      s3_p0n = s3_p0n + $signed(EW'($signed(s3_a0[k*AW+:AW]))) * $signed(EW'($signed(s3_n[k*MW+:MW])));
      s3_num = s3_num + $signed(NUMW'($signed(s3_nrm[k*NW+:NW]))) * $signed(NUMW'($signed(s3_a0[k*AW+:AW])));
    end
  end
  assign s3_e0 = s3_p1m;  // A1 . (A2 x d)
  assign s3_e1 = -s3_p0m;  // -A0 . (A2 x d)
  assign s3_e2 = s3_p0n;  // A0 . (A1 x d)
  localparam int W3 = 3 * EW + NUMW + 2 * TW + TAGW;
  logic [W3-1:0] r3;
  always_ff @(posedge clk) if (ld[3]) r3 <= {s3_e0, s3_e1, s3_e2, s3_num, s3_tmin, s3_tlim, s3_tag};

  // ---- step 4: decide, prepare the division -------------------------------------------------------------
  logic signed [EW-1:0] s4_e0, s4_e1, s4_e2;
  logic signed [NUMW-1:0] s4_num;
  logic [TW-1:0] s4_tmin, s4_tlim;
  logic [TAGW-1:0] s4_tag;
  assign {s4_e0, s4_e1, s4_e2, s4_num, s4_tmin, s4_tlim, s4_tag} = r3;

  logic signed [EW-1:0] s4_det;  // |det| < 2^(2B+2F+D+3): exact in EW bits
  logic signed [EW-1:0] s4_den;  // det >>> 2F: exact, |den| < 2^DENM
  logic s4_neg, s4_pos, s4_ok, s4_sgn, s4_ovf;
  logic [DENM-1:0] s4_aden;
  logic [NUMW-1:0] s4_anum;
  logic [XT-1:0] s4_x, s4_r0;
  assign s4_det = s4_e0 + s4_e1 + s4_e2;
  assign s4_den = s4_det >>> (2 * F);
  assign s4_neg = s4_e0[EW-1] | s4_e1[EW-1] | s4_e2[EW-1];
  assign s4_pos = (~s4_e0[EW-1] & (|s4_e0)) | (~s4_e1[EW-1] & (|s4_e1)) | (~s4_e2[EW-1] & (|s4_e2));
  assign s4_ok = ~(s4_neg & s4_pos) & (|s4_det);
  assign s4_sgn = s4_num[NUMW-1] ^ s4_den[EW-1];  // the quotient is negative (or zero)
  assign s4_aden = DENM'(s4_den[EW-1] ? -s4_den : s4_den);
  assign s4_anum = s4_num[NUMW-1] ? -s4_num : s4_num;  // < 2^(NUMW-1)
  assign s4_x = XT'(s4_anum) << S;
  assign s4_r0 = s4_x >> QWP;
  assign s4_ovf = s4_r0 >= XT'(s4_aden);  // the quotient needs more than QWP bits: saturate

  // The divider's payload: remainder, {dividend bits not yet used, quotient bits}, |den|, and what rides along.
  localparam int WP = 3 + 3 * EW + 2 * TW + TAGW;
  localparam int WD = DENM + QWP + DENM + WP;
  logic [WD-1:0] dv[DS+1];  // dv[k]: the register after divider stage k (dv[0]: after step 4)
  logic [WD-1:0] dn[DS];  // what divider stage k computes from dv[k]

  // ---- steps 5 .. 4+DS: restoring division, BPS quotient bits per stage ------------------------------------
  for (genvar k = 0; k < DS; k++) begin : g_div
    logic [DENM-1:0] rem, den, rem_n;
    logic [QWP-1:0] xq, xq_n;
    logic [WP-1:0] pay;
    assign {rem, xq, den, pay} = dv[k];
    always_comb begin : b_steps
      logic [DENM:0] sh, trial;
      rem_n = rem;
      xq_n  = xq;
      for (int j = 0; j < BPS; j++) begin
        sh = {rem_n, xq_n[QWP-1]};
        trial = sh - {1'b0, den};
        xq_n = {xq_n[QWP-2:0], ~trial[DENM]};  // quotient bit: sh >= den
        rem_n = trial[DENM] ? sh[DENM-1:0] : trial[DENM-1:0];
      end
    end
    assign dn[k] = {rem_n, xq_n, den, pay};
  end

  always_ff @(posedge clk) begin
    if (ld[4])
      dv[0] <= {DENM'(s4_r0), QWP'(s4_x), s4_aden, s4_ok, s4_sgn, s4_ovf, s4_e1, s4_e2, s4_det, s4_tmin, s4_tlim,
                s4_tag};
    for (int k = 0; k < DS; k++) if (ld[5+k]) dv[k+1] <= dn[k];
  end

  // ---- step LATENCY: sign, round, saturate, compare --------------------------------------------------------
  logic [DENM-1:0] f_rem, f_den;
  logic [QWP-1:0] f_q;
  logic f_ok, f_sgn, f_ovf;
  logic signed [EW-1:0] f_e1, f_e2, f_det;
  logic signed [TW-1:0] f_tmin, f_tlim;
  logic [TAGW-1:0] f_tag;
  assign {f_rem, f_q, f_den, f_ok, f_sgn, f_ovf, f_e1, f_e2, f_det, f_tmin, f_tlim, f_tag} = dv[DS];

  logic f_nz, f_rnd, f_hit;
  logic signed [QSW-1:0] f_qs, f_v;
  logic [DENM-1:0] f_r;
  logic [DENM:0] f_r2;
  logic signed [TW-1:0] f_t;
  assign f_nz = |f_rem;
  assign f_qs = f_sgn ? -$signed(QSW'(f_q)) - QSW'(f_nz) : $signed(QSW'(f_q));  // floor(num' 2^S / den')
  assign f_r = (f_sgn & f_nz) ? f_den - f_rem : f_rem;
  assign f_r2 = {f_r, 1'b0};
  assign f_rnd = (f_r2 > {1'b0, f_den}) | ((f_r2 == {1'b0, f_den}) & (S > 0) & f_qs[0]);
  assign f_v = f_qs + QSW'(f_rnd);
  always_comb begin
    if (f_ovf) f_t = f_sgn ? -TLIM : TLIM;
    else if (f_qs >= QHI) f_t = TLIM;  // q >= qmax
    else if (f_qs < -QHI) f_t = -TLIM;  // q < -qmax
    else if (f_v > QLIM) f_t = TLIM;
    else if (f_v < -QLIM) f_t = -TLIM;
    else f_t = TW'(f_v);
  end
  assign f_hit = f_ok & (f_t >= f_tmin) & (f_t <= f_tlim) & (f_t > -TLIM) & (f_t < TLIM);

  localparam int WO = 1 + TW + 3 * EW + TAGW;
  logic [WO-1:0] ro;
  always_ff @(posedge clk) if (ld[LATENCY]) ro <= {f_hit, f_t, f_e1, f_e2, f_det, f_tag};
  assign {out_hit, out_t, out_e1, out_e2, out_det, out_tag} = ro;
endmodule
