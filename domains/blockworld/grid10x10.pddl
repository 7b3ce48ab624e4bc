;; The 10 x 10 blockworld: ten 2 x 2 regions anchored (lower-left cell, x y) as in the
;; blockworld branch of RAraghavarora/anticipatory_rl: red (0,0) blue (3,0) green (6,0)
;; cyan (8,1) pink (0,3) orange (3,4) brown (7,4), white1 (0,7) white2 (4,8) white3 (8,7);
;; a region still holds one block. A move costs 25 x the straight-line distance between
;; the regions' centres, rounded to a whole unit (that source charges 25 per unit of
;; path length of a roadmap path; an unobstructed one is the straight line). Blocks a-e
;; are coloured, f-h white. The :init placement and robot position are the first
;; choices of domain.toml's [[reset]] entries.
(define (problem blockworld-grid10x10)
  (:domain blockworld)
  (:objects
    red blue green cyan pink orange brown - colored-region
    white1 white2 white3 - white-region
    a b c d e - colored-block
    f g h - white-block
    b_blue b_cyan c_pink d_cyan d_pink e_pink - single-job
    a_brown_d_blue a_cyan_b_red a_orange_c_blue a_red_e_pink b_blue_e_brown b_brown_d_blue b_brown_e_red b_green_d_orange b_green_e_cyan b_orange_c_pink b_pink_c_red d_green_e_orange d_pink_e_red d_red_e_orange - pair-job)
  (:init
    (robot-at orange) (hand-free)
    (at a green) (at b pink) (at c red) (at d white1) (at e orange) (at f brown) (at g white2) (at h blue)
    ;; the task library: what each job wants
    (wants b_blue b blue)
    (wants b_cyan b cyan)
    (wants c_pink c pink)
    (wants d_cyan d cyan)
    (wants d_pink d pink)
    (wants e_pink e pink)
    (wants a_brown_d_blue a brown) (wants a_brown_d_blue d blue)
    (wants a_cyan_b_red a cyan) (wants a_cyan_b_red b red)
    (wants a_orange_c_blue a orange) (wants a_orange_c_blue c blue)
    (wants a_red_e_pink a red) (wants a_red_e_pink e pink)
    (wants b_blue_e_brown b blue) (wants b_blue_e_brown e brown)
    (wants b_brown_d_blue b brown) (wants b_brown_d_blue d blue)
    (wants b_brown_e_red b brown) (wants b_brown_e_red e red)
    (wants b_green_d_orange b green) (wants b_green_d_orange d orange)
    (wants b_green_e_cyan b green) (wants b_green_e_cyan e cyan)
    (wants b_orange_c_pink b orange) (wants b_orange_c_pink c pink)
    (wants b_pink_c_red b pink) (wants b_pink_c_red c red)
    (wants d_green_e_orange d green) (wants d_green_e_orange e orange)
    (wants d_pink_e_red d pink) (wants d_pink_e_red e red)
    (wants d_red_e_orange d red) (wants d_red_e_orange e orange)
    (= (total-cost) 0)
    (= (move-cost red blue) 75) (= (move-cost red green) 150) (= (move-cost red cyan) 202) (= (move-cost red pink) 75) (= (move-cost red orange) 125) (= (move-cost red brown) 202) (= (move-cost red white1) 175) (= (move-cost red white2) 224) (= (move-cost red white3) 266)
    (= (move-cost blue red) 75) (= (move-cost blue green) 75) (= (move-cost blue cyan) 127) (= (move-cost blue pink) 106) (= (move-cost blue orange) 100) (= (move-cost blue brown) 141) (= (move-cost blue white1) 190) (= (move-cost blue white2) 202) (= (move-cost blue white3) 215)
    (= (move-cost green red) 150) (= (move-cost green blue) 75) (= (move-cost green cyan) 56) (= (move-cost green pink) 168) (= (move-cost green orange) 125) (= (move-cost green brown) 103) (= (move-cost green white1) 230) (= (move-cost green white2) 206) (= (move-cost green white3) 182)
    (= (move-cost cyan red) 202) (= (move-cost cyan blue) 127) (= (move-cost cyan green) 56) (= (move-cost cyan pink) 206) (= (move-cost cyan orange) 146) (= (move-cost cyan brown) 79) (= (move-cost cyan white1) 250) (= (move-cost cyan white2) 202) (= (move-cost cyan white3) 150)
    (= (move-cost pink red) 75) (= (move-cost pink blue) 106) (= (move-cost pink green) 168) (= (move-cost pink cyan) 206) (= (move-cost pink orange) 79) (= (move-cost pink brown) 177) (= (move-cost pink white1) 100) (= (move-cost pink white2) 160) (= (move-cost pink white3) 224)
    (= (move-cost orange red) 125) (= (move-cost orange blue) 100) (= (move-cost orange green) 125) (= (move-cost orange cyan) 146) (= (move-cost orange pink) 79) (= (move-cost orange brown) 100) (= (move-cost orange white1) 106) (= (move-cost orange white2) 103) (= (move-cost orange white3) 146)
    (= (move-cost brown red) 202) (= (move-cost brown blue) 141) (= (move-cost brown green) 103) (= (move-cost brown cyan) 79) (= (move-cost brown pink) 177) (= (move-cost brown orange) 100) (= (move-cost brown white1) 190) (= (move-cost brown white2) 125) (= (move-cost brown white3) 79)
    (= (move-cost white1 red) 175) (= (move-cost white1 blue) 190) (= (move-cost white1 green) 230) (= (move-cost white1 cyan) 250) (= (move-cost white1 pink) 100) (= (move-cost white1 orange) 106) (= (move-cost white1 brown) 190) (= (move-cost white1 white2) 103) (= (move-cost white1 white3) 200)
    (= (move-cost white2 red) 224) (= (move-cost white2 blue) 202) (= (move-cost white2 green) 206) (= (move-cost white2 cyan) 202) (= (move-cost white2 pink) 160) (= (move-cost white2 orange) 103) (= (move-cost white2 brown) 125) (= (move-cost white2 white1) 103) (= (move-cost white2 white3) 103)
    (= (move-cost white3 red) 266) (= (move-cost white3 blue) 215) (= (move-cost white3 green) 182) (= (move-cost white3 cyan) 150) (= (move-cost white3 pink) 224) (= (move-cost white3 orange) 146) (= (move-cost white3 brown) 79) (= (move-cost white3 white1) 200) (= (move-cost white3 white2) 103))
  ;; A layout's own goal: the library's last task, d_red_e_orange.
  (:goal (and (at d red) (at e orange) (hand-free)))
  (:metric minimize (total-cost)))
