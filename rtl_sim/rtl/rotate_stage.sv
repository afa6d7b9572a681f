// rotate_stage: the rotation stage in front of the box unit for oriented nodes (hwmodel/format/oriented_aabb.h):
// the ray's origin and direction turned into the node's frame with the rotation table's integer matrix M, exactly
// as hw::rotate_ray (hwmodel/datapath/oriented_aabb_test.h) does before the reciprocals of the rotated direction:
//   out_o[a] = M[a][0] o[0] + M[a][1] o[1] + M[a][2] o[2]     (F + rot_bits fraction bits)
//   out_d[a] = M[a][0] d[0] + M[a][1] d[1] + M[a][2] d[2]     (D + rot_bits fraction bits)
// The matrix comes in on ports: the table (format/rotation_table.h) is a ROM of `rotations` x 9 entries indexed by
// the node's rotation field, outside this stage.
// Widths (signed, two's complement): origin OB = B + G + F + 1 bits (|o| < 2^(B+G+F)), direction DB = D + 2 bits
// (|d| <= 2^D), entries MB = rot_bits + 2 bits (|m| <= 2^rot_bits); each sum of three products fits
// OB + MB + 1 and DB + MB + 1 bits.
// Pipeline: the 18 products registered in stage 1, the sums in stage 2: LATENCY 2, a new ray every clock, no
// handshake (out_valid is in_valid two clocks later; the box unit's valid/ready stalls the stage ahead of it).
module rotate_stage #(
    parameter  int OB  = 39,
    parameter  int DB  = 26,
    parameter  int MB  = 14,
    localparam int OOB = OB + MB + 1,  // rotated origin bits
    localparam int ODB = DB + MB + 1   // rotated direction bits
) (
    input  logic                  clk,
    input  logic                  rst,        // synchronous, active high: clears the valid bits
    input  logic                  in_valid,
    input  logic signed [ OB-1:0] in_o0,
    input  logic signed [ OB-1:0] in_o1,
    input  logic signed [ OB-1:0] in_o2,
    input  logic signed [ DB-1:0] in_d0,
    input  logic signed [ DB-1:0] in_d1,
    input  logic signed [ DB-1:0] in_d2,
    input  logic signed [ MB-1:0] in_m00,
    input  logic signed [ MB-1:0] in_m01,
    input  logic signed [ MB-1:0] in_m02,
    input  logic signed [ MB-1:0] in_m10,
    input  logic signed [ MB-1:0] in_m11,
    input  logic signed [ MB-1:0] in_m12,
    input  logic signed [ MB-1:0] in_m20,
    input  logic signed [ MB-1:0] in_m21,
    input  logic signed [ MB-1:0] in_m22,
    output logic                  out_valid,
    output logic signed [OOB-1:0] out_o0,
    output logic signed [OOB-1:0] out_o1,
    output logic signed [OOB-1:0] out_o2,
    output logic signed [ODB-1:0] out_d0,
    output logic signed [ODB-1:0] out_d1,
    output logic signed [ODB-1:0] out_d2
);
  localparam int PO = OB + MB, PD = DB + MB;  // product bits
  // Sign-extended operands (replication: yosys 0.23 reads no casts to an expression's width).
  logic signed [PO-1:0] o0, o1, o2;
  logic signed [PD-1:0] d0, d1, d2;
  logic signed [PO-1:0] mo00, mo01, mo02, mo10, mo11, mo12, mo20, mo21, mo22;
  logic signed [PD-1:0] md00, md01, md02, md10, md11, md12, md20, md21, md22;
  assign o0 = {{(PO - OB){in_o0[OB-1]}}, in_o0};
  assign o1 = {{(PO - OB){in_o1[OB-1]}}, in_o1};
  assign o2 = {{(PO - OB){in_o2[OB-1]}}, in_o2};
  assign d0 = {{(PD - DB){in_d0[DB-1]}}, in_d0};
  assign d1 = {{(PD - DB){in_d1[DB-1]}}, in_d1};
  assign d2 = {{(PD - DB){in_d2[DB-1]}}, in_d2};
  assign mo00 = {{(PO - MB){in_m00[MB-1]}}, in_m00};
  assign mo01 = {{(PO - MB){in_m01[MB-1]}}, in_m01};
  assign mo02 = {{(PO - MB){in_m02[MB-1]}}, in_m02};
  assign mo10 = {{(PO - MB){in_m10[MB-1]}}, in_m10};
  assign mo11 = {{(PO - MB){in_m11[MB-1]}}, in_m11};
  assign mo12 = {{(PO - MB){in_m12[MB-1]}}, in_m12};
  assign mo20 = {{(PO - MB){in_m20[MB-1]}}, in_m20};
  assign mo21 = {{(PO - MB){in_m21[MB-1]}}, in_m21};
  assign mo22 = {{(PO - MB){in_m22[MB-1]}}, in_m22};
  assign md00 = {{(PD - MB){in_m00[MB-1]}}, in_m00};
  assign md01 = {{(PD - MB){in_m01[MB-1]}}, in_m01};
  assign md02 = {{(PD - MB){in_m02[MB-1]}}, in_m02};
  assign md10 = {{(PD - MB){in_m10[MB-1]}}, in_m10};
  assign md11 = {{(PD - MB){in_m11[MB-1]}}, in_m11};
  assign md12 = {{(PD - MB){in_m12[MB-1]}}, in_m12};
  assign md20 = {{(PD - MB){in_m20[MB-1]}}, in_m20};
  assign md21 = {{(PD - MB){in_m21[MB-1]}}, in_m21};
  assign md22 = {{(PD - MB){in_m22[MB-1]}}, in_m22};

  // Stage 1: the 18 products.
  logic signed [PO-1:0] po00, po01, po02, po10, po11, po12, po20, po21, po22;
  logic signed [PD-1:0] pd00, pd01, pd02, pd10, pd11, pd12, pd20, pd21, pd22;
  logic v1;
  always_ff @(posedge clk) begin
    po00 <= mo00 * o0;
    po01 <= mo01 * o1;
    po02 <= mo02 * o2;
    po10 <= mo10 * o0;
    po11 <= mo11 * o1;
    po12 <= mo12 * o2;
    po20 <= mo20 * o0;
    po21 <= mo21 * o1;
    po22 <= mo22 * o2;
    pd00 <= md00 * d0;
    pd01 <= md01 * d1;
    pd02 <= md02 * d2;
    pd10 <= md10 * d0;
    pd11 <= md11 * d1;
    pd12 <= md12 * d2;
    pd20 <= md20 * d0;
    pd21 <= md21 * d1;
    pd22 <= md22 * d2;
    v1 <= rst ? 1'b0 : in_valid;
  end

  // Stage 2: the sums, sign-extended to the output widths.
  logic signed [OOB-1:0] eo00, eo01, eo02, eo10, eo11, eo12, eo20, eo21, eo22;
  logic signed [ODB-1:0] ed00, ed01, ed02, ed10, ed11, ed12, ed20, ed21, ed22;
  assign eo00 = {{(OOB - PO){po00[PO-1]}}, po00};
  assign eo01 = {{(OOB - PO){po01[PO-1]}}, po01};
  assign eo02 = {{(OOB - PO){po02[PO-1]}}, po02};
  assign eo10 = {{(OOB - PO){po10[PO-1]}}, po10};
  assign eo11 = {{(OOB - PO){po11[PO-1]}}, po11};
  assign eo12 = {{(OOB - PO){po12[PO-1]}}, po12};
  assign eo20 = {{(OOB - PO){po20[PO-1]}}, po20};
  assign eo21 = {{(OOB - PO){po21[PO-1]}}, po21};
  assign eo22 = {{(OOB - PO){po22[PO-1]}}, po22};
  assign ed00 = {{(ODB - PD){pd00[PD-1]}}, pd00};
  assign ed01 = {{(ODB - PD){pd01[PD-1]}}, pd01};
  assign ed02 = {{(ODB - PD){pd02[PD-1]}}, pd02};
  assign ed10 = {{(ODB - PD){pd10[PD-1]}}, pd10};
  assign ed11 = {{(ODB - PD){pd11[PD-1]}}, pd11};
  assign ed12 = {{(ODB - PD){pd12[PD-1]}}, pd12};
  assign ed20 = {{(ODB - PD){pd20[PD-1]}}, pd20};
  assign ed21 = {{(ODB - PD){pd21[PD-1]}}, pd21};
  assign ed22 = {{(ODB - PD){pd22[PD-1]}}, pd22};
  always_ff @(posedge clk) begin
    out_o0 <= eo00 + eo01 + eo02;
    out_o1 <= eo10 + eo11 + eo12;
    out_o2 <= eo20 + eo21 + eo22;
    out_d0 <= ed00 + ed01 + ed02;
    out_d1 <= ed10 + ed11 + ed12;
    out_d2 <= ed20 + ed21 + ed22;
    out_valid <= rst ? 1'b0 : v1;
  end
endmodule
