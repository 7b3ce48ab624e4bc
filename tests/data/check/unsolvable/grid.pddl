;; The 5x5 grid of the minimal example. Cells are named xXyY, except the
;; receptacles a = (0,0), b = (4,0), c = (2,4). The apple spawns on c; the
;; robot's start cell is drawn at each world reset (domain.toml).
(define (problem minimal-grid)
  (:domain minimal)
  (:objects
    a x1y0 x2y0 x3y0 b x0y1 x1y1 x2y1 x3y1 x4y1 x0y2 x1y2 x2y2 x3y2 x4y2 x0y3 x1y3 x2y3 x3y3 x4y3 x0y4 x1y4 c x3y4 x4y4 - cell
    apple - fruit)
  (:init
    (robot-at x2y2) (hand-free)
    (at apple c)
    (= (total-cost) 0)
    (receptacle a) (receptacle b) (receptacle c)
    (adjacent a x1y0) (adjacent a x0y1) (adjacent x0y1 x1y1) (adjacent x0y1 x0y2) (adjacent x0y1 a) (adjacent x0y2 x1y2)
    (adjacent x0y2 x0y3) (adjacent x0y2 x0y1) (adjacent x0y3 x1y3) (adjacent x0y3 x0y4) (adjacent x0y3 x0y2) (adjacent x0y4 x1y4)
    (adjacent x0y4 x0y3) (adjacent x1y0 x2y0) (adjacent x1y0 a) (adjacent x1y0 x1y1) (adjacent x1y1 x2y1) (adjacent x1y1 x0y1)
    (adjacent x1y1 x1y2) (adjacent x1y1 x1y0) (adjacent x1y2 x2y2) (adjacent x1y2 x0y2) (adjacent x1y2 x1y3) (adjacent x1y2 x1y1)
    (adjacent x1y3 x2y3) (adjacent x1y3 x0y3) (adjacent x1y3 x1y4) (adjacent x1y3 x1y2) (adjacent x1y4 c) (adjacent x1y4 x0y4)
    (adjacent x1y4 x1y3) (adjacent x2y0 x3y0) (adjacent x2y0 x1y0) (adjacent x2y0 x2y1) (adjacent x2y1 x3y1) (adjacent x2y1 x1y1)
    (adjacent x2y1 x2y2) (adjacent x2y1 x2y0) (adjacent x2y2 x3y2) (adjacent x2y2 x1y2) (adjacent x2y2 x2y3) (adjacent x2y2 x2y1)
    (adjacent x2y3 x3y3) (adjacent x2y3 x1y3) (adjacent x2y3 c) (adjacent x2y3 x2y2) (adjacent c x3y4) (adjacent c x1y4)
    (adjacent c x2y3) (adjacent x3y0 b) (adjacent x3y0 x2y0) (adjacent x3y0 x3y1) (adjacent x3y1 x4y1) (adjacent x3y1 x2y1)
    (adjacent x3y1 x3y2) (adjacent x3y1 x3y0) (adjacent x3y2 x4y2) (adjacent x3y2 x2y2) (adjacent x3y2 x3y3) (adjacent x3y2 x3y1)
    (adjacent x3y3 x4y3) (adjacent x3y3 x2y3) (adjacent x3y3 x3y4) (adjacent x3y3 x3y2) (adjacent x3y4 x4y4) (adjacent x3y4 c)
    (adjacent x3y4 x3y3) (adjacent b x3y0) (adjacent b x4y1) (adjacent x4y1 x3y1) (adjacent x4y1 x4y2) (adjacent x4y1 b)
    (adjacent x4y2 x3y2) (adjacent x4y2 x4y3) (adjacent x4y2 x4y1) (adjacent x4y3 x3y3) (adjacent x4y3 x4y4) (adjacent x4y3 x4y2)
    (adjacent x4y4 x3y4) (adjacent x4y4 x4y3))
  (:goal (and (hand-free) (not (exists (?t - thing) (at ?t c)))))
  (:metric minimize (total-cost)))
